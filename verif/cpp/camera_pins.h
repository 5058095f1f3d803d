// Shared by the Verilator harnesses that replay camera pins (pipeline_harness.cpp,
// system_harness.cpp): the pin files, the clocks (their command-line arguments,
// edges and bookkeeping) and the pin drive.
// The build caches hash this header with the harnesses (verif.verilator.sources_digest).
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

// A camera-pin file: little-endian uint16 per PCLK cycle,
// (stopped << 15) | (vsync << 9) | (href << 8) | data (sim.camera.pack_pins);
// ``stopped``: the camera's PCLK does not rise in that cycle (sim.camera.stop_clock).
constexpr uint16_t CLOCK_STOPPED = 1u << 15;
constexpr uint16_t CAMERA_IDLE = 1u << 9;  // after the last sample: VSYNC high
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

// Both cameras' pin files; false, with a message, if one cannot be read.
inline bool read_cameras(char* const* paths, std::vector<uint16_t> pins[2]) {
    for (int k = 0; k < 2; ++k) {
        if (!read_pins(paths[k], pins[k])) {
            std::fprintf(stderr, "cannot read %s\n", paths[k]);
            return false;
        }
    }
    return true;
}

// Both cameras are past their last sample.
inline bool cameras_done(const long index[2], const std::vector<uint16_t> pins[2]) {
    return index[0] >= static_cast<long>(pins[0].size()) &&
           index[1] >= static_cast<long>(pins[1].size());
}

struct Clock {
    long half;   // half period, ps
    long next;   // time of the next toggle, ps
    bool level;

    void toggle() {
        level = !level;
        next += half;
    }
};

// The pipeline clock (high at time 0) and the two cameras' PCLK from the five
// arguments SYNC_PS LEFT_PS LEFT_PHASE RIGHT_PS RIGHT_PHASE
// (verif.clocks.Clocks.camera_args).
inline void camera_clocks(char* const* args, Clock& sync, Clock& left, Clock& right) {
    const long sync_ps = std::atol(args[0]);
    sync = {sync_ps / 2, sync_ps / 2, true};
    left = {std::atol(args[1]) / 2, std::atol(args[2]), false};
    right = {std::atol(args[3]) / 2, std::atol(args[4]), false};
}

// The time of the next edge of any of ``n`` clocks.
inline long next_edge(const Clock* clocks, int n) {
    long t = clocks[0].next;
    for (int k = 1; k < n; ++k)
        if (clocks[k].next < t) t = clocks[k].next;
    return t;
}

// Sample ``index`` of a camera's pins; after the last one the camera idles.
inline uint16_t camera_sample(const std::vector<uint16_t>& pins, long index) {
    return index < static_cast<long>(pins.size()) ? pins[index] : CAMERA_IDLE;
}

// Put a sample on camera ``cam``'s (0 left, 1 right) data and sync pins.
template <class Top>
void drive_word(Top* top, int cam, uint16_t word) {
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

// The camera's PCLK line: its clock's level, held low through a stopped cycle
// (the sample put on the pins at the falling edge before says so).
inline bool camera_clock_line(bool level, uint16_t word) {
    return level && !(word & CLOCK_STOPPED);
}
