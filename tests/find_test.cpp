// `align3d find` (find.hpp) and its pieces. Oracles: the generator's ground truth (bin-picking
// scenes with known poses and visible fractions, scored by ADD-S and BOP's matching,
// instance_match.hpp), closed forms (a pinhole's intrinsics recovered exactly; the symmetry of a
// surface of revolution, of a box and of the bracket, which has none) and the reader's own file.
#include "align3d/find.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <stdexcept>
#include <tuple>

#include "align3d/error.hpp"
#include "align3d/instance_match.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/synth/bin_picking.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

namespace fs = std::filesystem;
using synth::BinPart;

// The scene as `align3d synth --scene bin` writes it and `align3d find` reads it: the PCD stores
// float32 coordinates.
FindScene scene_of(const synth::BinPickingScene& s) {
  std::vector<Eigen::Vector3d> image = s.cloud.positions;
  for (Eigen::Vector3d& p : image) p = p.cast<float>().cast<double>();
  return organized_scene(image, static_cast<std::size_t>(s.cloud.width),
                         static_cast<std::size_t>(s.cloud.height));
}

struct Scored {
  FindResult result;
  InstanceMatch match;
  std::vector<TrueInstance> truth;  // the generator's instances, in its order
};

// Finds the part in a generated scene and scores the poses against the truth (BOP: ADD-S below
// 10 % of the diameter; instances at least half visible count).
Scored find_and_score(BinPart part, int instances, std::uint64_t seed, int threads = 2,
                      const CostSettings& cost = {}, int distractors = 3) {
  synth::BinPickingSettings bs;
  bs.part = part, bs.instances = instances, bs.seed = seed, bs.threads = threads;
  bs.distractors = distractors;
  const synth::BinPickingScene scene = synth::make_bin_picking_scene(bs);
  const PpfModel model = build_find_model(scene.model, kFindVoxelFraction, threads);
  FindSettings fs;
  fs.threads = threads;
  fs.cost = cost;
  Scored out{find(model, scene_of(scene), fs), {}, {}};
  const PointCloud samples = sample_surface(scene.model, 2000);
  const AddS add_s(samples.positions);
  std::vector<Eigen::Isometry3d> found;
  for (const auto& f : out.result.instances) found.push_back(f.T_scene_model);
  for (const auto& t : scene.instances) out.truth.push_back({t.T_camera_model, t.visible_fraction});
  out.match = match_instances(add_s, found, out.truth, 0.1 * bounding_box_diagonal(scene.model));
  return out;
}

TEST(FindScene, OrganizedRangeImageRecoversThePinhole) {
  // A tilted plane seen by a known pinhole: the fitted intrinsics are the camera's.
  const int w = 64, h = 48;
  const double fx = 300, fy = 310, cx = 31.2, cy = 24.7;
  std::vector<Eigen::Vector3d> image(w * h, Eigen::Vector3d::Constant(NAN));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      if ((u * 7 + v * 3) % 11 == 0) continue;  // holes
      const double z = 800 + 2.0 * u - 1.5 * v;
      image[v * w + u] = {(u - cx) * z / fx, (v - cy) * z / fy, z};
    }
  const FindScene scene = organized_scene(image, w, h);
  const RangeImage r = organized_range_image(scene.cloud, scene.pixels, w, h, scene.T_cloud_camera);
  EXPECT_NEAR(r.fx, fx, 1e-6);
  EXPECT_NEAR(r.fy, fy, 1e-6);
  EXPECT_NEAR(r.cx, cx, 1e-6);
  EXPECT_NEAR(r.cy, cy, 1e-6);
  EXPECT_TRUE(std::isnan(r.depth[0]));  // (0, 0) is a hole
  EXPECT_NEAR(r.depth[r.pixel(5, 4)], 800 + 10 - 6, 1e-4);
}

// The same kind of image seen by a camera at a known pose in a world frame: given that pose, the
// rays agree with it (kept, off by less than 1e-6°); given the pose with its orientation turned by
// a half turn about x (the placeholder VIEWPOINT of PCL's Kinect frames) or by 30° about a tilted
// axis, the orientation the rays give replaces it, equal to the true one, and the intrinsics are
// the camera's. A mirrored image (columns reversed) fits no right-handed camera: an error.
TEST(FindScene, OrganizedRangeImageResectsAWrongOrientation) {
  const int w = 80, h = 60;
  const double fx = 280, fy = 285, cx = 41.3, cy = 28.9;
  const Eigen::Isometry3d truth = Eigen::Translation3d(0.3, -0.2, 1.5) *
                                  Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -0.5).normalized());
  auto image_of = [&](bool mirrored) {
    std::vector<Eigen::Vector3d> image(w * h, Eigen::Vector3d::Constant(NAN));
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        if ((u * 5 + v * 3) % 13 == 0) continue;  // holes
        const double z = 1.2 + 0.2 * std::sin(u / 9.0) * std::cos(v / 7.0);
        const int at = v * w + (mirrored ? w - 1 - u : u);
        image[at] = truth * Eigen::Vector3d((u - cx) * z / fx, (v - cy) * z / fy, z);
      }
    return image;
  };
  const FindScene scene = organized_scene(image_of(false), w, h);
  auto range = [&](const Eigen::Isometry3d& given) {
    return organized_range_image(scene.cloud, scene.pixels, w, h, given);
  };
  const RangeImage kept = range(truth);
  EXPECT_FALSE(kept.orientation_from_rays);
  EXPECT_LT(kept.given_orientation_error_deg, 1e-6);
  for (const Eigen::Isometry3d& wrong :
       {Eigen::Isometry3d(truth * Eigen::AngleAxisd(std::numbers::pi, Eigen::Vector3d::UnitX())),
        Eigen::Isometry3d(truth * Eigen::AngleAxisd(std::numbers::pi / 6,
                                                    Eigen::Vector3d(1, 1, 0).normalized()))}) {
    const RangeImage r = range(wrong);
    EXPECT_TRUE(r.orientation_from_rays);
    EXPECT_NEAR(r.given_orientation_error_deg,
                Eigen::AngleAxisd(wrong.linear().transpose() * truth.linear()).angle() * 180 /
                    std::numbers::pi,
                1e-6);
    EXPECT_TRUE(r.T_cloud_camera.isApprox(truth, 1e-9)) << r.T_cloud_camera.matrix();
    EXPECT_NEAR(r.fx, fx, 1e-6);
    EXPECT_NEAR(r.fy, fy, 1e-6);
    EXPECT_NEAR(r.cx, cx, 1e-6);
    EXPECT_NEAR(r.cy, cy, 1e-6);
  }
  const FindScene mirrored = organized_scene(image_of(true), w, h);
  EXPECT_THROW(organized_range_image(mirrored.cloud, mirrored.pixels, w, h, truth), DataError);
}

// The depth noise a triangulating sensor leaves (σ constant in inverse depth, so σ_z ∝ z²),
// measured from the image: a slanted plane from 1 to 3 m with Gaussian noise of σ = 1e-3 / m in
// 1/z. The estimate holds it to 15 % at every depth bin, and depth_sigma(z) follows z²·σ.
// The sensor's field: a band of 40 columns without any return at the right (as a Kinect's) and a
// row band at the top lie outside it; a hole inside does not.
TEST(FindScene, DepthNoiseAndTheSensorsFieldAreMeasuredFromTheImage) {
  const int w = 320, h = 240;
  const double f = 300, sigma_inverse = 1e-3;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, sigma_inverse);
  std::vector<Eigen::Vector3d> image(w * h, Eigen::Vector3d::Constant(NAN));
  for (int v = 10; v < h; ++v)
    for (int u = 0; u < w - 40; ++u) {
      if (std::hypot(u - 100, v - 100) < 8) continue;  // a hole in the field
      const double z = 1 / (1 / (1.0 + 2.0 * u / (w - 40)) + noise(rng));
      image[v * w + u] = Eigen::Vector3d((u - w / 2.0) * z / f, (v - h / 2.0) * z / f, z);
    }
  const FindScene scene = organized_scene(image, w, h);
  const RangeImage r =
      organized_range_image(scene.cloud, scene.pixels, w, h, Eigen::Isometry3d::Identity());
  ASSERT_FALSE(r.noise_depth.empty());
  for (std::size_t b = 0; b < r.noise_depth.size(); ++b) {
    EXPECT_NEAR(r.noise_inverse[b], sigma_inverse, 0.15 * sigma_inverse) << r.noise_depth[b];
    EXPECT_NEAR(r.depth_sigma(r.noise_depth[b]),
                r.noise_depth[b] * r.noise_depth[b] * sigma_inverse,
                0.15 * r.noise_depth[b] * r.noise_depth[b] * sigma_inverse);
  }
  EXPECT_GT(r.noise_depth.back(), 2.5);
  EXPECT_LT(r.noise_depth.front(), 1.5);
  EXPECT_TRUE(r.in_field(100, 100));  // the hole
  EXPECT_TRUE(r.in_field(5, 200));
  EXPECT_FALSE(r.in_field(w - 20, 120));  // the right band
  EXPECT_FALSE(r.in_field(150, 4));       // the top rows
  // A projected (unorganized) image has no band: all of it is the field, and no noise measured.
  const RangeImage projected = projected_range_image(scene.cloud, Eigen::Isometry3d::Identity());
  EXPECT_TRUE(projected.in_field(0, 0));
  EXPECT_EQ(projected.depth_sigma(2.0), 0.0);
}

TEST(FindScene, PcdReaderKeepsEachPointsPixel) {
  const fs::path path = fs::temp_directory_path() / "align3d_find_organized.pcd";
  PointCloud grid;
  for (int i = 0; i < 12; ++i)
    grid.positions.emplace_back(i % 2 ? NAN : static_cast<double>(i), 0.0, 1000.0);
  io::PcdLayout layout;
  layout.width = 4, layout.height = 3;
  io::write_pcd(path, grid, io::PcdEncoding::kBinaryCompressed, layout);
  const FindScene scene = read_find_scene(path);
  fs::remove(path);
  ASSERT_EQ(scene.cloud.size(), 6u);
  EXPECT_EQ(scene.width, 4u);
  EXPECT_EQ(scene.height, 3u);
  for (std::size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(scene.pixels[k], 2 * k);
    EXPECT_EQ(scene.cloud.positions[k].x(), static_cast<double>(2 * k));
  }
}

// (A box's 2-fold turns are not detected yet: its voxel centroids are not symmetric themselves,
// and a tolerance loose enough for them takes the bracket's near 2-fold turn for a symmetry.)
TEST(Symmetry, DetectsTheTurnedPartAndNoneOnTheBracket) {
  double voxel = 0;
  const auto symmetry_of = [&voxel](const TriangleMesh& mesh) {
    const PpfModel m = build_find_model(mesh);
    voxel = m.voxel;
    return detect_symmetry(m.points, 0.1 * m.voxel);
  };
  const Symmetry flange = symmetry_of(synth::bin_part_mesh(BinPart::kFlange));
  EXPECT_EQ(flange.kind, Symmetry::Kind::kContinuous) << flange.name();
  // About the turning axis: the model's z axis, through its origin.
  EXPECT_GT(std::abs(flange.axis.z()), 0.999) << flange.name();
  const Eigen::Vector3d off_axis = flange.centre - flange.centre.dot(flange.axis) * flange.axis;
  EXPECT_LT(off_axis.norm(), 0.1 * voxel) << flange.centre.transpose();
  EXPECT_EQ(symmetry_of(synth::bin_part_mesh(BinPart::kBracket)).kind, Symmetry::Kind::kNone);
}

TEST(Symmetry, CanonicalPoseIsTheSameForEveryEquivalentPose) {
  Symmetry s;
  s.kind = Symmetry::Kind::kDiscrete, s.order = 4, s.centre = {1, 2, 3};
  Eigen::Isometry3d T = Eigen::Translation3d(10, -5, 900) *
                        Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 0.5).normalized());
  const Eigen::Isometry3d c = canonical_pose(T, s);
  for (int k = 1; k < 4; ++k) {
    const Eigen::Isometry3d other = canonical_pose(T * s.turn(k * std::numbers::pi / 2), s);
    EXPECT_LT((other.matrix() - c.matrix()).norm(), 1e-9) << k;
  }
  s.kind = Symmetry::Kind::kContinuous;
  const Eigen::Isometry3d cc = canonical_pose(T, s);
  EXPECT_LT((canonical_pose(T * s.turn(2.1), s).matrix() - cc.matrix()).norm(), 1e-9);
  EXPECT_THROW(parse_symmetry("w", PointCloud{}), std::invalid_argument);
  EXPECT_EQ(parse_symmetry("z:6", PointCloud{}).order, 6);
}

// Issue 16's targets on a fixed set chosen beforehand (seeds 1–4, 6 parts and 3 distractors a
// bin, both parts: 45 instances at least half visible): recall and precision of 0.95 less the
// sampling error of so few instances (±0.03 at one σ; two σ: 0.9 for the recall), precision
// 0.95 as is. The bench (bench/compare_find.py, 24 scenes, and 108 development and held-out ones)
// measures the rates themselves.
TEST(Find, FindsBothPartsOfAFixedSceneSet) {
  std::size_t tp = 0, fp = 0, counted = 0;
  for (const BinPart part : {BinPart::kBracket, BinPart::kFlange})
    for (const std::uint64_t seed : {1, 2, 3, 4}) {
      const Scored s = find_and_score(part, 6, seed);
      tp += s.match.true_positives, fp += s.match.false_positives, counted += s.match.counted;
      for (const auto& f : s.result.instances) {
        EXPECT_GE(f.score, kFindMinScore);  // as scored at the reported pose
        EXPECT_FALSE(f.points.empty());
      }
    }
  EXPECT_GE(counted, 40u);
  EXPECT_GE(static_cast<double>(tp), 0.9 * static_cast<double>(counted)) << tp << "/" << counted;
  EXPECT_GE(static_cast<double>(tp), 0.95 * static_cast<double>(tp + fp)) << tp << " / " << fp;
}

// A mostly flat part (the plate: two 110 × 70 faces, 10 mm apart, small features) is not matched
// into the bin's floor or walls, the planes it resembles most: no false positive in four bins of
// six plates, and the plates are found (at least half of them: those standing on an edge show
// the camera a 10 mm strip and a face at a grazing angle, bench/README.md).
TEST(Find, AFlatPartIsNotMatchedIntoTheFloorOrTheWalls) {
  std::size_t tp = 0, counted = 0;
  for (const std::uint64_t seed : {1, 2, 3, 4}) {
    const Scored s = find_and_score(BinPart::kPlate, 6, seed, 2, {}, 0);
    EXPECT_EQ(s.match.false_positives, 0u) << "seed " << seed;
    tp += s.match.true_positives, counted += s.match.counted;
  }
  EXPECT_GE(counted, 20u);
  EXPECT_GE(2 * tp, counted) << tp << "/" << counted;
}

// Parts partly under their neighbours (60–90 % visible) are found: the score judges what the
// camera sees of a part, not how much of it is covered, and a touching neighbour does not pull
// the refined pose off it.
TEST(Find, FindsPartsPartlyUnderTheirNeighbours) {
  const Scored s = find_and_score(BinPart::kBracket, 6, 4);
  std::size_t covered = 0;
  for (std::size_t k = 0; k < s.truth.size(); ++k) {
    const double visible = s.truth[k].visible_fraction;
    if (visible < 0.6 || visible > 0.9) continue;
    ++covered;
    EXPECT_NE(std::find(s.match.match.begin(), s.match.match.end(), static_cast<int>(k)),
              s.match.match.end())
        << "instance " << k << ", " << visible << " visible";
  }
  EXPECT_GE(covered, 2u);  // the scene holds such parts (else the test proves nothing)
  EXPECT_EQ(s.match.false_positives, 0u);
}

// A face of the part fitted into the bin's inner wall, the rest of the part behind the wall (seen
// at a grazing angle, the wall beyond the part's outline is too narrow a strip for the larger-
// surface test), is not reported: what hides the part is the surface it lies on. And the parts
// the camera sees whole are found, though the points' z-buffer leaves some of their own far
// faces behind their near ones (which must not count as hidden by that face's plane). Two scenes
// of bench/compare_find.py's development sets (seeds 704 and 718), where such poses scored 0.60
// and 0.80 before.
TEST(Find, APartsFaceInTheBinsWallIsNoInstance) {
  for (const auto& [seed, instances, distractors] :
       {std::tuple{704, 3, 5}, std::tuple{718, 4, 5}}) {
    const Scored s = find_and_score(BinPart::kBracket, instances, seed, 2, {}, distractors);
    EXPECT_EQ(s.match.false_positives, 0u) << "seed " << seed;
    EXPECT_EQ(s.match.true_positives, s.match.counted) << "seed " << seed;
    EXPECT_GE(s.match.counted, 3u);
  }
}

TEST(Find, ReportsEachTurnedPartOnceInCanonicalPose) {
  const Scored s = find_and_score(BinPart::kFlange, 6, 2);
  EXPECT_EQ(s.result.symmetry.kind, Symmetry::Kind::kContinuous);
  EXPECT_EQ(s.match.false_positives, 0u);  // a second pose of one flange would be one
  EXPECT_GE(s.match.true_positives + 1, s.match.counted);
  for (const auto& f : s.result.instances)  // canonical: turning it changes nothing
    EXPECT_LT(
        (canonical_pose(f.T_scene_model * s.result.symmetry.turn(1.0), s.result.symmetry).matrix() -
         f.T_scene_model.matrix())
            .norm(),
        1e-6);
}

// The final refinement with another cost (GICP, scene normals estimated toward the camera; the
// symmetric objective with a Tukey kernel from the noise) finds the same instances of a scene.
TEST(Find, EveryCostFindsTheSameInstances) {
  const Scored plane = find_and_score(BinPart::kBracket, 6, 1);
  for (const CostSettings& cost : {CostSettings{IcpMethod::kGicp, std::nullopt, 0},
                                   CostSettings{IcpMethod::kSymmetric, RobustKernel::kTukey, 0}}) {
    const Scored s = find_and_score(BinPart::kBracket, 6, 1, 2, cost);
    EXPECT_EQ(s.match.true_positives, plane.match.true_positives) << to_string(cost.method);
    EXPECT_EQ(s.match.false_positives, plane.match.false_positives) << to_string(cost.method);
    EXPECT_GT(s.match.true_positives, 0u);
  }
}

TEST(Find, EmptyBinGivesNoInstance) {
  synth::BinPickingSettings bs;
  bs.instances = 0, bs.distractors = 2;
  const synth::BinPickingScene scene = synth::make_bin_picking_scene(bs);
  const FindResult r = find(build_find_model(scene.model), scene_of(scene));
  EXPECT_TRUE(r.instances.empty());
  EXPECT_GT(r.plane_points, 0u);  // the floor was found and kept out of the voting
}

TEST(Find, ModelLargerThanTheSceneIsAClearError) {
  const TriangleMesh part = synth::bin_part_mesh(BinPart::kBracket);
  const PpfModel model = build_find_model(part);
  // The part in metres, the scene in millimetres: the same mistake the other way round.
  FindScene scene;
  for (const auto& p : sample_surface(part, 500).positions)
    scene.cloud.positions.push_back(p / 1000 + Eigen::Vector3d(0, 0, 1));
  try {
    (void)find(model, scene);
    FAIL() << "no error";
  } catch (const DataError& e) {
    EXPECT_EQ(e.subject(), "model");
    EXPECT_NE(std::string(e.what()).find("larger than the whole scene"), std::string::npos);
  }
}

// ppf_hypotheses' place cap (max_per_place) only skips clusters, and it gives the parts that draw
// fewer votes a hypothesis: on the points of 12 brackets (the floor, walls and distractors left
// out), 12 capped hypotheses reach every part at least half visible that any cluster reaches (a
// hypothesis puts the model's centroid within a quarter diameter of the true one's); the 12 with
// the most votes do not.
TEST(PpfHypotheses, APlaceCapLetsTheLessSeenPartsIn) {
  synth::BinPickingSettings bs;
  bs.instances = 12, bs.seed = 3, bs.threads = 2;
  const synth::BinPickingScene scene = synth::make_bin_picking_scene(bs);
  const PpfModel model = build_find_model(scene.model, kFindVoxelFraction, 2);
  PointCloud parts;
  for (std::size_t i = 0; i < scene.cloud.positions.size(); ++i)
    if (scene.cloud.shape[i] >= 0) parts.positions.push_back(scene.cloud.positions[i]);
  const PointCloud voting = ppf_scene(parts, model.voxel, Eigen::Vector3d::Zero(), 2);
  const std::size_t n = 12, cap = 1;  // a hypothesis per place: as many as there are parts
  const auto all = ppf_hypotheses(model, voting, Symmetry{}, 100000, 2);
  const auto capped = ppf_hypotheses(model, voting, Symmetry{}, n, 2, cap);
  ASSERT_EQ(capped.size(), n);
  std::size_t at = 0;  // capped ⊂ all, in order, the same poses
  for (const auto& h : capped) {
    while (at < all.size() && !h.T_scene_model.isApprox(all[at].T_scene_model, 0)) ++at;
    ASSERT_LT(at, all.size()) << "a capped hypothesis is not among the uncapped ones";
  }
  const Eigen::Vector3d centre = centroid(model.points);
  const auto reached = [&](auto begin, auto end) {
    std::size_t count = 0;
    for (const auto& t : scene.instances) {
      if (t.visible_fraction < 0.5) continue;
      count += std::any_of(begin, end, [&](const PpfHypothesis& h) {
        return (h.T_scene_model * centre - t.T_camera_model * centre).norm() <
               0.25 * model.diameter;
      });
    }
    return count;
  };
  const std::size_t by_capped = reached(capped.begin(), capped.end());
  const std::size_t by_first = reached(all.begin(), all.begin() + static_cast<long>(n));
  // Every part any hypothesis reaches is reached by the capped list; not by its first n.
  EXPECT_EQ(by_capped, reached(all.begin(), all.end()));
  EXPECT_LT(by_first, by_capped);
  EXPECT_GE(by_capped, 6u);  // the scene has such parts (else the test proves nothing)
}

// Whole parts and scans of them: the bin's CAD parts (the plate too, whose far side lies a few
// millimetres behind its near one) are whole; the points a depth camera saw of one of them in a
// generated bin, without normals, are a partial model seen from the camera's side (its sensor
// estimated within 45° of the camera's direction).
TEST(FindModel, PartsAreWholeAndTheirScansPartial) {
  for (BinPart part : {BinPart::kBracket, BinPart::kFlange, BinPart::kPlate}) {
    SCOPED_TRACE(synth::to_string(part));
    const PpfModel whole = build_find_model(synth::bin_part_mesh(part));
    EXPECT_FALSE(model_side(whole.points).partial);
    synth::BinPickingSettings bs;
    bs.part = part, bs.instances = 1, bs.distractors = 0, bs.seed = 7;
    const synth::BinPickingScene scene = synth::make_bin_picking_scene(bs);
    PointCloud seen;
    for (std::size_t k = 0; k < scene.cloud.positions.size(); ++k)
      if (scene.cloud.shape[k] == 0) seen.positions.push_back(scene.cloud.positions[k]);
    ASSERT_GT(seen.size(), 200u);
    const PpfModel scan = build_find_model(seen);
    const ModelSide side = model_side(scan.points);
    EXPECT_TRUE(side.partial) << side.hidden_share;
    EXPECT_GT(side.seen_from.dot(-centroid(seen).normalized()), std::cos(std::numbers::pi / 4));
  }
}

// A part taught from a scan of it in one generated bin (its points, no normals, moved by a known
// pose) is found in that bin among distractors, once, where the cut undoes the move.
TEST(Find, FindsAPartTaughtFromAScanOfIt) {
  synth::BinPickingSettings bs;
  bs.part = BinPart::kBracket, bs.instances = 1, bs.distractors = 3, bs.seed = 11;
  const synth::BinPickingScene scene = synth::make_bin_picking_scene(bs);
  const Eigen::Isometry3d moved = Eigen::Translation3d(40, -25, 300) *
                                  Eigen::AngleAxisd(2.0, Eigen::Vector3d(1, -1, 0.5).normalized());
  PointCloud taught;
  for (std::size_t k = 0; k < scene.cloud.positions.size(); ++k)
    if (scene.cloud.shape[k] == 0) taught.positions.push_back(moved * scene.cloud.positions[k]);
  FindSettings fs;
  fs.threads = 2;
  const FindResult r = find(build_find_model(taught, kFindVoxelFraction, 2), scene_of(scene), fs);
  EXPECT_TRUE(r.model_side.partial);
  ASSERT_EQ(r.instances.size(), 1u);
  const Eigen::Isometry3d truth = moved.inverse();
  const Eigen::Vector3d c = centroid(taught);
  EXPECT_LT(test::rotation_error_deg(r.instances[0].T_scene_model, truth), 2.0);
  EXPECT_LT((r.instances[0].T_scene_model * c - truth * c).norm(), 0.02 * r.model_diameter);
}

TEST(Find, SameResultWithOneAndTwoThreads) {
  const Scored one = find_and_score(BinPart::kBracket, 4, 3, 1);
  const Scored two = find_and_score(BinPart::kBracket, 4, 3, 2);
  ASSERT_EQ(one.result.instances.size(), two.result.instances.size());
  for (std::size_t k = 0; k < one.result.instances.size(); ++k)
    EXPECT_EQ(one.result.instances[k].T_scene_model.matrix(),
              two.result.instances[k].T_scene_model.matrix());
}

TEST(Find, SavedModelKeepsItsOutwardNormals) {
  const PpfModel model = build_find_model(synth::bin_part_mesh(BinPart::kBracket));
  const fs::path path = fs::temp_directory_path() / "align3d_find_model.ppf";
  save_ppf_model(path, model);
  const PpfModel back = load_ppf_model(path);
  fs::remove(path);
  EXPECT_TRUE(back.outward);
  EXPECT_EQ(back.refs, model.refs);
  EXPECT_THROW((void)find(build_ppf_model(model.points, model.voxel), FindScene{}),
               std::invalid_argument);  // a registration model: normals not outward
}

}  // namespace
}  // namespace align3d
