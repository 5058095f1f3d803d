// Shared by the Verilator harnesses that replay camera pins (pipeline_harness.cpp,
// system_harness.cpp): the pin files, the clock bookkeeping and the pin drive.
// The build caches hash this header with the harnesses (verif.verilator.sources_digest).
#pragma once

#include <cstdint>
#include <cstdio>
#include <vector>

// A camera-pin file: little-endian uint16 per PCLK cycle,
// (vsync << 9) | (href << 8) | data (sim.camera.pack_pins).
inline bool read_pins(const char* path, std::vector<uint16_t>& out) {
    FILE* f = std::fopen(path, "rb");
    if (!f) return false;
    std::fseek(f, 0, SEEK_END);
    const long bytes = std::ftell(f);
    std::fseek(f, 0, SEEK_SET);
    out.resize(bytes / 2);
    const bool ok = std::fread(out.data(), 2, out.size(), f) == out.size();
    std::fclose(f);
    return ok;
}

struct Clock {
    long half;   // half period, ps
    long next;   // time of the next toggle, ps
    bool level;
};

// Put sample ``index`` of camera ``cam`` (0 left, 1 right) on the model's pins;
// after the last sample the camera idles with VSYNC high.
template <class Top>
void drive_camera(Top* top, int cam, const std::vector<uint16_t>& pins, long index) {
    const uint16_t word = index < static_cast<long>(pins.size()) ? pins[index] : (1u << 9);
    if (cam == 0) {
        top->left_vsync = (word >> 9) & 1;
        top->left_href = (word >> 8) & 1;
        top->left_data = word & 0xff;
    } else {
        top->right_vsync = (word >> 9) & 1;
        top->right_href = (word >> 8) & 1;
        top->right_data = word & 0xff;
    }
}
