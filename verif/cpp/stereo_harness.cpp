// Full-frame harness for the Verilated StereoMatcher (hdl/stereo_matcher.py).
//
// No Python runs per cycle: the pixels come from a file, the clock, reset and
// the idle gaps (valid low) are driven here, and every output beat is written
// to a file.
//
// usage: stereo_harness IN OUT FRAMES PIXELS THRESHOLD IDLE_PERCENT SEED
//   IN   FRAMES * PIXELS pairs of little-endian uint16: left, right
//   OUT  the disparity of every output beat, little-endian uint16
// Prints one JSON line: cycles, outputs, seconds, cycles_per_second.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "Vstereo_matcher.h"
#include "verilated.h"

static uint32_t rng_state = 1;
static uint32_t next_random() {  // xorshift32
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 17;
    rng_state ^= rng_state << 5;
    return rng_state;
}

int main(int argc, char** argv) {
    if (argc != 8) {
        std::fprintf(stderr, "usage: %s IN OUT FRAMES PIXELS THRESHOLD IDLE_PERCENT SEED\n",
                     argv[0]);
        return 2;
    }
    const long frames = std::atol(argv[3]);
    const long pixels = std::atol(argv[4]);
    const unsigned threshold = std::atoi(argv[5]);
    const unsigned idle_percent = std::atoi(argv[6]);
    rng_state = static_cast<uint32_t>(std::atol(argv[7])) | 1u;
    const long total = frames * pixels;

    std::vector<uint16_t> input(2 * total);
    FILE* fin = std::fopen(argv[1], "rb");
    if (!fin || std::fread(input.data(), 2, input.size(), fin) != input.size()) {
        std::fprintf(stderr, "cannot read %ld pixel pairs from %s\n", total, argv[1]);
        return 1;
    }
    std::fclose(fin);
    std::vector<uint16_t> output;
    output.reserve(total);

    VerilatedContext* context = new VerilatedContext;
    Vstereo_matcher* top = new Vstereo_matcher{context};
    top->threshold = threshold;
    top->in_valid = 0;
    top->rst = 1;
    for (int i = 0; i < 4; ++i) {
        top->clk = 0; top->eval();
        top->clk = 1; top->eval();
    }
    top->rst = 0;

    long pos = 0;
    long cycles = 0;
    long quiet = 0;  // cycles since the last input, to end after the last output
    const long max_cycles = 4 * (total + 1000000L) + 1000;
    auto start = std::chrono::steady_clock::now();
    while (static_cast<long>(output.size()) < total && cycles < max_cycles) {
        const bool present = pos < total && (next_random() % 100) >= idle_percent;
        top->clk = 0;
        top->in_valid = present;
        if (present) {
            top->in_left = input[2 * pos];
            top->in_right = input[2 * pos + 1];
        }
        top->eval();
        const bool accepted = present && top->in_ready;
        if (top->out_valid) output.push_back(static_cast<uint16_t>(top->out_disparity));
        top->clk = 1;
        top->eval();
        ++cycles;
        if (accepted) ++pos;
        if (pos >= total) ++quiet;
    }
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    top->final();

    FILE* fout = std::fopen(argv[2], "wb");
    if (!fout || std::fwrite(output.data(), 2, output.size(), fout) != output.size()) {
        std::fprintf(stderr, "cannot write %s\n", argv[2]);
        return 1;
    }
    std::fclose(fout);
    std::printf("{\"cycles\": %ld, \"outputs\": %zu, \"seconds\": %.6f, \"cycles_per_second\": %.1f}\n",
                cycles, output.size(), seconds, cycles / (seconds > 0 ? seconds : 1e-9));
    delete top;
    delete context;
    return static_cast<long>(output.size()) == total ? 0 : 3;
}
