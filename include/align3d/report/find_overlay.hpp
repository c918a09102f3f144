// What `align3d find` writes besides its JSON report: the depth image with every instance marked
// (PNG), and the scene with the model placed at every instance (coloured PLY). Both colour an
// instance by its rank (1 = best score) with instance_color, so one part has one colour in both.
// Each file is written atomically (OutputError on failure, nothing left behind).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>

#include "align3d/coarse/ppf.hpp"
#include "align3d/find.hpp"
#include "align3d/point_cloud.hpp"

namespace align3d::report {

// The colour of the instance of `rank` (>= 1; std::invalid_argument otherwise), sRGB bytes: a
// qualitative palette of 12 saturated colours, none grey (the depth and the scene are grey),
// cycling from rank 13. From Trubetskoy's "20 distinct colours" (2017), in its order, which puts
// the most distinct first.
std::array<std::uint8_t, 3> instance_color(int rank);
inline constexpr int kInstancePaletteSize = 12;

// result.image as a PNG of its width × height pixels: the depth in grey, near light and far dark,
// scaled to the 1st-99th percentile of the valid depths (one depth: mid grey); pixels with no
// return (NaN) dark blue. Each instance's mask is filled translucent in its colour and outlined
// opaque (1 pixel, 2 from 240 pixels up), with its rank in bold white on a dark halo at the mask's
// centroid (the mask pixel nearest to it when it falls outside, as in a ring). A caption across the
// bottom: "2 instances · scores 0.91, 0.84" (as many scores as fit, then "…"), or "no instance
// found".
//
// The mask: the pixels whose scene point (image.point) the instance explains (its `points`),
// closed morphologically (dilated then eroded by a square) so that explained pixels a model voxel
// apart, or two with one missing between them, read as one region: radius the voxel's size in
// pixels at the mask's median depth, at least 1 and at most 16. A pixel claimed by several closed
// masks goes to the best rank. An instance none of whose points is in the image gets no mask and no
// label.
//
// Throws std::invalid_argument for an image of size 0 (no RangeImage) or whose depth or point
// arrays do not hold width × height values; OutputError when the file cannot be written.
void write_find_image(const std::filesystem::path& path, const FindResult& result);

// Binary PLY in the scene's frame (io/ply_attributes.hpp): every scene point in its order, grey,
// or pale in the colour of the instance that explains it; then, per instance by rank, the model's
// points (model.points) moved by its T_scene_model, in its colour. Property int `instance`: 0 for
// a scene point, the rank for a model point. Throws std::invalid_argument when an instance names a
// point index outside `scene`; OutputError when the file cannot be written.
void write_find_overlay(const std::filesystem::path& path, const PointCloud& scene,
                        const PpfModel& model, const FindResult& result);

}  // namespace align3d::report
