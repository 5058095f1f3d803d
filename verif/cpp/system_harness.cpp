// Harness for the Verilated StereogestCore (soc/core.py): the whole FPGA side
// with its five clocks, camera pins replayed from files, and a command loop on
// stdin/stdout so that Python (the unmodified HPS application) reaches the
// Avalon-MM slaves while the cameras keep streaming.
//
// usage: system_harness LEFT RIGHT SYNC_PS LEFT_PS LEFT_PHASE RIGHT_PS RIGHT_PHASE
//                       CONFIG_PS VGA_PS STAGE VGA_WIDTH VGA_HEIGHT
//   LEFT, RIGHT   camera pins per PCLK cycle, little-endian uint16
//                 (stopped << 15) | (vsync << 9) | (href << 8) | data
//                 (sim.camera.pack_pins); after the last sample the camera idles
//                 with VSYNC high (until "a" gives more)
//   *_PS          clock periods (and camera phases) in picoseconds
//   STAGE         stage_select (SW[9:7]) for the whole run
//   VGA_*         active area of the VGA mode
// Commands (one per line, one reply line each):
//   r ADDR        Avalon read at byte address ADDR (0x000-0x0ff FIFO slave,
//                 0x100-0x1ff UART slave, 0x200-0x2ff posture slave) -> "VALUE"
//   w ADDR VALUE  Avalon write -> "ok"
//   t NS          run NS nanoseconds -> "CYCLES DONE" (DONE: both cameras played out)
//   v PATH        the next whole VGA frame's active area, red channel, to PATH
//                 (uint8, row-major), only the VGA clock running -> "ok"
//   u             UART TX line changes since the last "u" -> "N PS LEVEL PS LEVEL ..."
//   a LEFT RIGHT  append these pin files to the cameras' (a long run feeds them in
//                 pieces; the samples played so far are freed) -> "ok"
//   q             -> one JSON line of statistics, then exit
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "Vstereogest_system.h"
#include "camera_pins.h"
#include "verilated.h"

enum { SYNC, LEFT, RIGHT, CONFIG, VGA, NCLOCKS };

struct System {
    VerilatedContext* context;
    Vstereogest_system* top;
    Clock clocks[NCLOCKS];
    std::vector<uint16_t> pins[2];
    long base[2] = {0, 0};  // camera sample number of pins[cam][0]
    long index[2] = {-1, -1};
    uint16_t word[2] = {CAMERA_IDLE, CAMERA_IDLE};
    long now = 0;       // ps
    long cycles = 0;    // sync rising edges
    long vga_cycles = 0;
    std::vector<long> tx_edges;
    int tx_level = 1;

    bool cameras_done() const {
        return index[0] >= base[0] + static_cast<long>(pins[0].size()) &&
               index[1] >= base[1] + static_cast<long>(pins[1].size());
    }

    // Drop the samples played, then append a pin file to camera ``cam``'s.
    bool append(int cam, const char* path) {
        std::vector<uint16_t> more;
        if (!read_pins(path, more)) return false;
        const long played = std::min<long>(std::max<long>(index[cam] - base[cam], 0),
                                           static_cast<long>(pins[cam].size()));
        pins[cam].erase(pins[cam].begin(), pins[cam].begin() + played);
        base[cam] += played;
        pins[cam].insert(pins[cam].end(), more.begin(), more.end());
        return true;
    }

    // Process the next clock event; returns true if it was a sync rising edge.
    bool step() {
        const long t = next_edge(clocks, NCLOCKS);
        now = t;
        bool sync_rise = false;
        for (int k = 0; k < NCLOCKS; ++k) {
            Clock& c = clocks[k];
            if (c.next != t) continue;
            c.toggle();
            if (k == SYNC && c.level) {
                sync_rise = true;
                ++cycles;
                top->reset = cycles < 8;
            }
            if (k == VGA && c.level) ++vga_cycles;
            if ((k == LEFT || k == RIGHT) && !c.level) {  // camera falling edge: next byte
                const int cam = k - LEFT;
                ++index[cam];
                word[cam] = camera_sample(pins[cam], index[cam] - base[cam]);
                drive_word(top, cam, word[cam]);
            }
        }
        top->clk = clocks[SYNC].level;
        top->cam_left_clk = camera_clock_line(clocks[LEFT].level, word[0]);
        top->cam_right_clk = camera_clock_line(clocks[RIGHT].level, word[1]);
        top->config_clk = clocks[CONFIG].level;
        top->vga_clk = clocks[VGA].level;
        top->eval();
        if (top->uart_tx != tx_level) {
            tx_level = top->uart_tx;
            tx_edges.push_back(now);
            tx_edges.push_back(tx_level);
        }
        return sync_rise;
    }

    void sync_cycles(long n) {
        while (n > 0)
            if (step()) --n;
    }

    // the slave at a bridge offset: 0x000 FIFO, 0x100 UART, 0x200 posture
    uint32_t read(uint32_t address) {
        const uint32_t slave = address >> 8, word = (address & 0xff) >> 2;
        if (slave == 1) {
            top->uart_address = word;
            top->uart_read = 1;
        } else if (slave == 2) {
            top->posture_address = word;
            top->posture_read = 1;
        } else {
            top->fifo_address = word;
            top->fifo_read = 1;
        }
        sync_cycles(1);  // the slave sees the read at this edge
        top->fifo_read = 0;
        top->uart_read = 0;
        top->posture_read = 0;
        top->eval();
        // fixed read latency 1: readdata holds the value during the next cycle
        return slave == 1 ? top->uart_readdata
                          : slave == 2 ? top->posture_readdata : top->fifo_readdata;
    }

    void write(uint32_t address, uint32_t value) {
        const uint32_t slave = address >> 8, word = (address & 0xff) >> 2;
        if (slave == 1) {
            top->uart_address = word;
            top->uart_writedata = value;
            top->uart_write = 1;
        } else if (slave == 2) {
            top->posture_address = word;
            top->posture_writedata = value;
            top->posture_write = 1;
        } else {
            top->fifo_address = word;
            top->fifo_writedata = value;
            top->fifo_write = 1;
        }
        sync_cycles(1);
        top->fifo_write = 0;
        top->uart_write = 0;
        top->posture_write = 0;
        top->eval();
    }

    bool capture_vga(const char* path, int width, int height) {
        // Only the VGA clock runs: the scan reads the frame buffer in its own
        // domain, and the other domains would cost most of the evaluations.
        // Wait for the end of a vertical sync pulse (active low), then take the
        // first width*height samples with blank_n high, between VGA edges.
        std::vector<uint8_t> frame;
        frame.reserve(static_cast<size_t>(width) * height);
        const long start = now;
        Clock& c = clocks[VGA];
        int state = 0;  // 0: wait for vsync low, 1: wait for vsync high, 2: collect
        while (frame.size() < static_cast<size_t>(width) * height) {
            now = c.next;
            c.toggle();
            top->vga_clk = c.level;
            top->eval();
            if (c.level) {
                ++vga_cycles;
                continue;
            }
            const int vsync = top->vga_vsync, blank_n = top->vga_blank_n;
            if (state == 0 && !vsync) state = 1;
            else if (state == 1 && vsync) state = 2;
            else if (state == 2 && blank_n) frame.push_back(static_cast<uint8_t>(top->vga_r));
        }
        for (int k = 0; k < NCLOCKS; ++k)  // the others resume where they stopped
            if (k != VGA) clocks[k].next += now - start;
        FILE* f = std::fopen(path, "wb");
        if (!f) return false;
        const bool ok = std::fwrite(frame.data(), 1, frame.size(), f) == frame.size();
        std::fclose(f);
        return ok;
    }
};

int main(int argc, char** argv) {
    if (argc != 13) {
        std::fprintf(stderr, "usage: %s LEFT RIGHT SYNC_PS LEFT_PS LEFT_PHASE RIGHT_PS "
                             "RIGHT_PHASE CONFIG_PS VGA_PS STAGE VGA_WIDTH VGA_HEIGHT\n",
                     argv[0]);
        return 2;
    }
    System s;
    if (!read_cameras(argv + 1, s.pins)) return 1;
    camera_clocks(argv + 3, s.clocks[SYNC], s.clocks[LEFT], s.clocks[RIGHT]);
    s.clocks[CONFIG] = {std::atol(argv[8]) / 2, std::atol(argv[8]) / 2, true};
    s.clocks[VGA] = {std::atol(argv[9]) / 2, std::atol(argv[9]) / 2, true};
    const int vga_width = std::atoi(argv[11]), vga_height = std::atoi(argv[12]);

    s.context = new VerilatedContext;
    s.top = new Vstereogest_system{s.context};
    Vstereogest_system* top = s.top;
    top->stage_select = std::atoi(argv[10]);
    top->capture = 1;
    top->pause = 0;
    top->configure = 0;
    top->uart_rx = 1;
    top->left_vsync = 1;
    top->right_vsync = 1;
    top->reset = 1;
    top->clk = 1;
    top->config_clk = 1;
    top->vga_clk = 1;
    top->eval();

    auto start = std::chrono::steady_clock::now();
    std::string line;
    while (std::getline(std::cin, line)) {
        std::istringstream in(line);
        std::string cmd;
        in >> cmd;
        if (cmd == "r") {
            std::string a;
            in >> a;
            std::printf("%u\n", s.read(static_cast<uint32_t>(std::stoul(a, nullptr, 0))));
        } else if (cmd == "w") {
            std::string a, v;
            in >> a >> v;
            s.write(static_cast<uint32_t>(std::stoul(a, nullptr, 0)),
                    static_cast<uint32_t>(std::stoul(v, nullptr, 0)));
            std::printf("ok\n");
        } else if (cmd == "t") {
            long ns = 0;
            in >> ns;
            const long until = s.now + ns * 1000;
            while (s.now < until) s.step();
            std::printf("%ld %d\n", s.cycles, s.cameras_done() ? 1 : 0);
        } else if (cmd == "v") {
            std::string path;
            in >> path;
            std::printf(s.capture_vga(path.c_str(), vga_width, vga_height) ? "ok\n"
                                                                            : "error\n");
        } else if (cmd == "u") {
            std::printf("%zu", s.tx_edges.size() / 2);
            for (long v : s.tx_edges) std::printf(" %ld", v);
            std::printf("\n");
            s.tx_edges.clear();
        } else if (cmd == "a") {
            std::string left, right;
            in >> left >> right;
            std::printf(s.append(0, left.c_str()) && s.append(1, right.c_str())
                            ? "ok\n" : "error cannot read the pin files\n");
        } else if (cmd == "q") {
            break;
        } else {
            std::printf("error unknown command %s\n", cmd.c_str());
        }
        std::fflush(stdout);
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("{\"cycles\": %ld, \"vga_cycles\": %ld, \"leds\": %d, \"seconds\": %.6f, "
                "\"cycles_per_second\": %.1f, \"cameras_done\": %s}\n",
                s.cycles, s.vga_cycles, static_cast<int>(top->leds), seconds,
                s.cycles / (seconds > 0 ? seconds : 1e-9), s.cameras_done() ? "true" : "false");
    std::fflush(stdout);
    top->final();
    delete top;
    delete s.context;
    return 0;
}
