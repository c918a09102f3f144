// Plots the chapter's scene seen from above with the installed report library and checks the PNG:
// its signature, and the width and height in its IHDR chunk (the figure's requested size).
#include <algorithm>
#include <align3d/report/plot.hpp>
#include <align3d/synth/scenes.hpp>
#include <array>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace {

std::uint32_t big_endian(const unsigned char* p) {
  return std::uint32_t{p[0]} << 24 | std::uint32_t{p[1]} << 16 | std::uint32_t{p[2]} << 8 | p[3];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: plot_scene OUTDIR\n");
    return 2;
  }
  const align3d::synth::Scene scene = align3d::synth::make_conveyor_scene();
  align3d::report::Figure figure;
  figure.title = "Conveyor scene, top view";
  figure.x_label = "x (mm)";
  figure.y_label = "y (mm)";
  figure.equal_aspect = true;
  figure.width = 640;
  figure.height = 480;
  align3d::report::Series model{"model", {0.2, 0.3, 0.8}, {}};
  for (const auto& p : scene.model.positions) model.points.emplace_back(p.x(), p.y());
  figure.series.push_back(model);
  const std::filesystem::path stem = std::filesystem::path(argv[1]) / "scene_top";
  align3d::report::write_figure(figure, stem);

  std::ifstream png(stem.string() + ".png", std::ios::binary);
  std::array<unsigned char, 24> head{};
  png.read(reinterpret_cast<char*>(head.data()), head.size());
  const std::array<unsigned char, 8> signature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  const bool is_png = png && std::equal(signature.begin(), signature.end(), head.begin());
  const std::uint32_t width = big_endian(&head[16]), height = big_endian(&head[20]);
  std::printf("plot_scene: %s.png, %u x %u\n", stem.c_str(), width, height);
  return is_png && width == 640 && height == 480 ? 0 : 1;
}
