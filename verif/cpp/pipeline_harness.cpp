// Harness for the Verilated GesturePipeline (hdl/gesture_pipeline.py): three
// clocks (pipeline, left camera PCLK, right camera PCLK) with their own periods
// and phases, camera pins replayed from files, no Python per cycle.
//
// usage: pipeline_harness LEFT RIGHT OUT SYNC_PS LEFT_PS LEFT_PHASE RIGHT_PS RIGHT_PHASE
//                         DRAIN RESET_AT RESET_CYCLES VIDEO_SELECT VIDEO_OUT POSTURE_OUT
//   LEFT, RIGHT   camera pins per PCLK cycle, little-endian uint16
//                 (stopped << 15) | (vsync << 9) | (href << 8) | data
//                 (sim.camera.pack_pins); after the last sample the camera idles
//                 with VSYNC high
//   OUT           one record per frame: 7 little-endian int64
//                 (cycle, x, y, flag, centroid_x, centroid_y, area)
//   *_PS          clock periods and phases (first rising edge) in picoseconds
//   DRAIN         pipeline cycles run after both cameras' last sample
//   RESET_AT      pipeline cycle at which every domain is reset (-1: never),
//                 held for RESET_CYCLES pipeline cycles
//   VIDEO_SELECT  stage of the o_video output (hdl.gesture_pipeline.VIDEO_STAGES)
//   VIDEO_OUT     file for the o_video beats, uint16 (first << 8) | pixel, or "-"
//   POSTURE_OUT   file for the o_posture words, little-endian uint32 in order
// Prints one JSON line: cycles, records, frames, faults, seconds, cycles_per_second.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "Vgesture_pipeline.h"
#include "camera_pins.h"
#include "verilated.h"

int main(int argc, char** argv) {
    if (argc != 15) {
        std::fprintf(stderr, "usage: %s LEFT RIGHT OUT SYNC_PS LEFT_PS LEFT_PHASE RIGHT_PS "
                             "RIGHT_PHASE DRAIN RESET_AT RESET_CYCLES VIDEO_SELECT VIDEO_OUT "
                             "POSTURE_OUT\n",
                     argv[0]);
        return 2;
    }
    std::vector<uint16_t> pins[2];
    if (!read_cameras(argv + 1, pins)) return 1;
    Clock clocks[3];  // pipeline, left PCLK, right PCLK
    camera_clocks(argv + 4, clocks[0], clocks[1], clocks[2]);
    const long drain = std::atol(argv[9]);
    const long reset_at = std::atol(argv[10]);
    const long reset_cycles = std::atol(argv[11]);
    const int video_select = std::atoi(argv[12]);
    const bool want_video = std::strcmp(argv[13], "-") != 0;

    VerilatedContext* context = new VerilatedContext;
    Vgesture_pipeline* top = new Vgesture_pipeline{context};
    top->video_select = video_select;
    top->start = 1;
    top->pause = 0;
    top->left_vsync = 1;
    top->right_vsync = 1;
    top->clk = 1;
    top->rst = 1;
    top->cam_left_rst = 1;
    top->cam_right_rst = 1;
    top->eval();

    std::vector<int64_t> records;
    std::vector<uint16_t> video;
    std::vector<uint32_t> posture;
    long index[2] = {-1, -1};  // camera sample on the pins
    uint16_t word[2] = {CAMERA_IDLE, CAMERA_IDLE};
    long cycles = 0, done_at = -1;
    const long initial_reset = 8;
    auto start = std::chrono::steady_clock::now();
    while (done_at < 0 || cycles < done_at) {
        const long t = next_edge(clocks, 3);
        // the pipeline's outputs, sampled just before its rising edge
        if (clocks[0].next == t && !clocks[0].level) {
            if (top->out_valid) {
                const int64_t rec[7] = {cycles, top->out_x, top->out_y, top->out_flag,
                                        top->out_centroid_x, top->out_centroid_y,
                                        top->out_area};
                records.insert(records.end(), rec, rec + 7);
            }
            if (top->posture_valid) posture.push_back(top->posture_word);
            if (want_video && top->video_valid)
                video.push_back(static_cast<uint16_t>((top->video_first << 8) | top->video_pixel));
            ++cycles;
            const bool in_reset = cycles < initial_reset ||
                                  (reset_at >= 0 && cycles >= reset_at &&
                                   cycles < reset_at + reset_cycles);
            top->rst = in_reset;
            top->cam_left_rst = in_reset;
            top->cam_right_rst = in_reset;
        }
        for (int k = 0; k < 3; ++k) {
            Clock& c = clocks[k];
            if (c.next != t) continue;
            c.toggle();
            if (k > 0 && !c.level) {  // camera falling edge: the next byte on the pins
                const int cam = k - 1;
                word[cam] = camera_sample(pins[cam], ++index[cam]);
                drive_word(top, cam, word[cam]);
            }
        }
        top->clk = clocks[0].level;
        top->cam_left_clk = camera_clock_line(clocks[1].level, word[0]);
        top->cam_right_clk = camera_clock_line(clocks[2].level, word[1]);
        top->eval();
        if (done_at < 0 && cameras_done(index, pins)) done_at = cycles + drain;
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const long frames = top->frames, faults = top->faults;
    top->final();

    FILE* fout = std::fopen(argv[3], "wb");
    if (!fout || std::fwrite(records.data(), 8, records.size(), fout) != records.size()) {
        std::fprintf(stderr, "cannot write %s\n", argv[3]);
        return 1;
    }
    std::fclose(fout);
    if (want_video) {
        FILE* fv = std::fopen(argv[13], "wb");
        if (!fv || std::fwrite(video.data(), 2, video.size(), fv) != video.size()) {
            std::fprintf(stderr, "cannot write %s\n", argv[13]);
            return 1;
        }
        std::fclose(fv);
    }
    FILE* fp = std::fopen(argv[14], "wb");
    if (!fp || (!posture.empty() &&
                std::fwrite(posture.data(), 4, posture.size(), fp) != posture.size())) {
        std::fprintf(stderr, "cannot write %s\n", argv[14]);
        return 1;
    }
    std::fclose(fp);
    std::printf("{\"cycles\": %ld, \"records\": %zu, \"frames\": %ld, \"faults\": %ld, "
                "\"seconds\": %.6f, \"cycles_per_second\": %.1f}\n",
                cycles, records.size() / 7, frames, faults, seconds,
                cycles / (seconds > 0 ? seconds : 1e-9));
    delete top;
    delete context;
    return 0;
}
