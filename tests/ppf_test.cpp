// Point pair feature matching. Oracles: the synthetic scenes' ground truth composed with a known
// large perturbation of the scan (rotations PPF must find without any initial guess); bitwise
// equality across thread counts and across a save/load round trip; hand-corrupted model files;
// a box, whose 180° symmetries make the pose ambiguous by construction.
#include "align3d/coarse/ppf.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <numbers>
#include <string>
#include <vector>

#include "align3d/error.hpp"
#include "align3d/io/atomic_file.hpp"
#include "align3d/se3.hpp"
#include "align3d/synth/scenes.hpp"
#include "detail/fast_angle.hpp"
#include "detail/random.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

// The scan moved by a rotation of `deg` about a seeded random axis and a translation; `truth` is
// the pose that maps the moved scan into the model: T_model_scan · perturbation⁻¹.
struct Perturbed {
  PointCloud scan;
  Eigen::Isometry3d truth;
};

Perturbed perturb(const synth::Scene& scene, double deg, std::uint64_t seed) {
  Random rng(seed);
  Eigen::Vector3d axis(rng.normal(), rng.normal(), rng.normal());
  Eigen::Isometry3d P = Eigen::Isometry3d::Identity();
  P.linear() = Eigen::AngleAxisd(deg_to_rad(deg), axis.normalized()).toRotationMatrix();
  P.translation() =
      Eigen::Vector3d(rng.uniform(-30, 30), rng.uniform(-30, 30), rng.uniform(-30, 30));
  return {transformed(scene.scan, P), scene.T_model_scan * P.inverse()};
}

synth::Scene object_scene(const std::string& shape) {
  synth::ObjectSettings settings;
  settings.shape = shape;
  return synth::make_object_scene(settings);
}

GlobalSettings ppf_settings(int threads = 1) {
  GlobalSettings settings;
  settings.method = GlobalMethod::kPpf;
  settings.threads = threads;
  return settings;
}

void expect_recovered(const GlobalResult& r, const Eigen::Isometry3d& truth) {
  EXPECT_TRUE(r.success) << r.message;
  EXPECT_FALSE(r.ambiguous) << r.message;
  EXPECT_EQ(r.method, GlobalMethod::kPpf);
  EXPECT_LT(test::rotation_error_deg(r.T_target_source, truth), 5.0);
  EXPECT_LT(test::translation_error(r.T_target_source, truth), 2 * r.voxel);
  EXPECT_GT(r.score, 0);
  EXPECT_GT(r.candidates, 0u);
}

void expect_identical(const GlobalResult& a, const GlobalResult& b) {
  EXPECT_EQ(std::memcmp(a.T_target_source.matrix().data(), b.T_target_source.matrix().data(),
                        16 * sizeof(double)),
            0);
  EXPECT_EQ(a.success, b.success);
  EXPECT_EQ(a.score, b.score);
  EXPECT_EQ(a.overlap, b.overlap);
  EXPECT_EQ(a.candidates, b.candidates);
  EXPECT_EQ(a.ambiguous, b.ambiguous);
  EXPECT_EQ(a.message, b.message);
}

void expect_same_model(const PpfModel& a, const PpfModel& b) {
  EXPECT_EQ(a.voxel, b.voxel);
  EXPECT_EQ(a.diameter, b.diameter);
  EXPECT_EQ(a.angle_bins, b.angle_bins);
  EXPECT_EQ(a.points.positions, b.points.positions);
  EXPECT_EQ(a.points.normals, b.points.normals);
  EXPECT_EQ(a.keys, b.keys);
  EXPECT_EQ(a.offsets, b.offsets);
  EXPECT_EQ(a.refs, b.refs);
  EXPECT_EQ(a.alphas, b.alphas);
}

TEST(Ppf, RecoversLargeRotationOfBracket) {
  const synth::Scene scene = object_scene("bracket");
  const Perturbed p = perturb(scene, 150, 11);
  expect_recovered(ppf_register(p.scan, scene.model, ppf_settings()), p.truth);
}

TEST(Ppf, RecoversLargeRotationOfBumpySphere) {
  const synth::Scene scene = object_scene("bumpy-sphere");
  const Perturbed p = perturb(scene, 130, 12);
  expect_recovered(ppf_register(p.scan, scene.model, ppf_settings()), p.truth);
}

TEST(Ppf, RecoversLargeRotationOfChapterScene) {
  // 33.7 % of the scan is the intruder wall; the plane dominates the rest.
  const synth::Scene scene = synth::make_conveyor_scene();
  const Perturbed p = perturb(scene, 165, 13);
  expect_recovered(ppf_register(p.scan, scene.model, ppf_settings()), p.truth);
}

TEST(Ppf, SameResultWithOneAndTwoThreads) {
  const synth::Scene scene = object_scene("bumpy-sphere");
  const Perturbed p = perturb(scene, 120, 14);
  const PpfModel one =
      build_ppf_model(scene.model, global_voxel(scene.model, scene.model, ppf_settings()), 1);
  const PpfModel two =
      build_ppf_model(scene.model, global_voxel(scene.model, scene.model, ppf_settings()), 2);
  expect_same_model(one, two);
  expect_identical(ppf_match(one, p.scan, ppf_settings(1)),
                   ppf_match(one, p.scan, ppf_settings(2)));
}

// The hash table's layout (ppf.hpp): keys strictly increasing, each key's entries in reference
// order (the model's pairs are built by reference point and sorted stably by key: an unstable sort
// scrambles them), the offsets bounding every entry.
TEST(Ppf, ModelTableIsSortedByKeyThenReference) {
  const synth::Scene scene = object_scene("bracket");
  const PpfModel m =
      build_ppf_model(scene.model, global_voxel(scene.model, scene.model, ppf_settings()), 2);
  ASSERT_GT(m.keys.size(), 1000u);
  ASSERT_EQ(m.offsets.size(), m.keys.size() + 1);
  EXPECT_EQ(m.offsets.front(), 0u);
  EXPECT_EQ(m.offsets.back(), m.refs.size());
  EXPECT_EQ(m.alphas.size(), m.refs.size());
  std::size_t disordered = 0, several = 0;
  for (std::size_t k = 0; k < m.keys.size(); ++k) {
    if (k > 0) {
      EXPECT_LT(m.keys[k - 1], m.keys[k]) << k;
    }
    ASSERT_LT(m.offsets[k], m.offsets[k + 1]) << k;
    several += m.offsets[k + 1] - m.offsets[k] > 1;
    for (std::uint32_t e = m.offsets[k] + 1; e < m.offsets[k + 1]; ++e)
      disordered += m.refs[e - 1] > m.refs[e];
  }
  EXPECT_GT(several, 100u);  // the order within a key is tested
  EXPECT_EQ(disordered, 0u);
}

TEST(Ppf, SaveLoadRoundTripGivesIdenticalMatch) {
  test::TempDir dir("ppf_roundtrip");
  const synth::Scene scene = object_scene("bumpy-sphere");
  const Perturbed p = perturb(scene, 140, 15);
  const PpfModel built =
      build_ppf_model(scene.model, global_voxel(scene.model, scene.model, ppf_settings()));
  save_ppf_model(dir / "model.ppf", built);
  const PpfModel loaded = load_ppf_model(dir / "model.ppf");
  expect_same_model(built, loaded);
  const GlobalResult a = ppf_match(built, p.scan, ppf_settings());
  expect_identical(a, ppf_match(loaded, p.scan, ppf_settings()));
  expect_recovered(a, p.truth);
}

// A valid small model file's bytes, for the corruption tests.
class PpfFile : public ::testing::Test {
 protected:
  void SetUp() override {
    synth::ObjectSettings settings;
    settings.points = 1500;
    const synth::Scene scene = synth::make_object_scene(settings);
    save_ppf_model(dir_ / "good.ppf", build_ppf_model(scene.model, 6.0));
    std::ifstream in(dir_ / "good.ppf", std::ios::binary);
    bytes_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes_.size(), 56u);
  }
  std::filesystem::path write(const std::string& name, const std::string& content) {
    const auto path = dir_ / name;
    io::write_atomically(path, [&](std::ostream& out) { out << content; });
    return path;
  }
  void expect_io_error(const std::filesystem::path& path, const std::string& words) {
    try {
      (void)load_ppf_model(path);
      ADD_FAILURE() << "no IoError for " << path;
    } catch (const IoError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path.string()), std::string::npos) << what;
      EXPECT_NE(what.find("byte offset"), std::string::npos) << what;
      EXPECT_NE(what.find(words), std::string::npos) << what;
    }
  }
  void put_u64(std::string& s, std::size_t at, std::uint64_t v) {
    for (int b = 0; b < 8; ++b) s[at + b] = static_cast<char>((v >> (8 * b)) & 0xff);
  }
  test::TempDir dir_{"ppf_file"};
  std::string bytes_;
};

TEST_F(PpfFile, GoodFileLoads) { EXPECT_NO_THROW((void)load_ppf_model(dir_ / "good.ppf")); }

TEST_F(PpfFile, TruncatedFileThrowsIoError) {
  expect_io_error(write("header.ppf", bytes_.substr(0, 30)), "truncated header");
  expect_io_error(write("body.ppf", bytes_.substr(0, bytes_.size() - 3)), "file size");
  expect_io_error(write("empty.ppf", ""), "magic");
}

TEST_F(PpfFile, WrongMagicThrowsIoError) {
  std::string bad = bytes_;
  bad[1] = 'X';
  expect_io_error(write("magic.ppf", bad), "magic");
  expect_io_error(write("text.ppf", "ply\nformat ascii 1.0\nelement vertex 300\nend_header\n"),
                  "magic");
}

TEST_F(PpfFile, LyingSizesThrowIoErrorBeforeAllocating) {
  for (std::size_t field : {32u, 40u, 48u}) {  // point, key and entry counts
    std::string bad = bytes_;
    put_u64(bad, field, std::uint64_t{1} << 60);
    expect_io_error(write("huge" + std::to_string(field) + ".ppf", bad), "file size");
    put_u64(bad, field, 3);
    expect_io_error(write("small" + std::to_string(field) + ".ppf", bad), "file size");
  }
}

TEST_F(PpfFile, CorruptReferenceThrowsIoError) {
  std::string bad = bytes_;
  bad[bad.size() - 8] = static_cast<char>(0xff);  // the last entry's reference point, low bytes
  bad[bad.size() - 7] = static_cast<char>(0xff);
  bad[bad.size() - 6] = static_cast<char>(0xff);
  expect_io_error(write("ref.ppf", bad), "names point");
}

TEST(Ppf, PlainBoxIsAmbiguous) {
  Random rng(21);
  const PointCloud model = test::box_surface(6000, rng);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() =
      Eigen::AngleAxisd(deg_to_rad(140), Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(10, -20, 5);
  const PointCloud scene = transformed(test::box_surface(6000, rng), T);
  const GlobalResult r = ppf_register(scene, model, ppf_settings());
  EXPECT_TRUE(r.success) << r.message;
  EXPECT_TRUE(r.ambiguous) << r.message;
  EXPECT_NE(r.message.find("ambiguous"), std::string::npos);
  // Both poses lay the box onto itself: each is T⁻¹ up to one of the box's symmetries.
  for (const Eigen::Isometry3d& pose : {r.T_target_source, r.second_T_target_source}) {
    const Eigen::Matrix3d S = pose.linear() * T.linear();
    EXPECT_LT((S.cwiseAbs() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 0.05) << S;
  }
  EXPECT_GT(test::rotation_error_deg(r.T_target_source, r.second_T_target_source), 90.0);
}

TEST(Ppf, TooFewPointsThrowDataError) {
  PointCloud few;
  for (int i = 0; i < 5; ++i) few.positions.emplace_back(i, i * i, 0.5 * i);
  EXPECT_THROW((void)build_ppf_model(few, 0.1), DataError);
  PointCloud line;
  for (int i = 0; i < 100; ++i) line.positions.emplace_back(i, 2 * i, -i);
  EXPECT_THROW((void)build_ppf_model(line, 0.5), DataError);
  const synth::Scene scene = object_scene("bumpy-sphere");
  EXPECT_THROW((void)ppf_register(few, scene.model, ppf_settings()), DataError);
  EXPECT_THROW((void)ppf_register(scene.scan, few, ppf_settings()), DataError);
}

TEST(Ppf, InsufficientOverlapIsReportedNotHidden) {
  const synth::Scene scene = object_scene("bumpy-sphere");
  GlobalSettings settings = ppf_settings();
  settings.min_overlap = 0.99;  // the scan holds 4 % outliers: no pose can cover 99 %
  const GlobalResult r = ppf_register(scene.scan, scene.model, settings);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("minimum"), std::string::npos) << r.message;
}

// The features' acos against libm's on a fine grid of [−1, 1] and at its ends: within its
// published 2e-8 bound (Abramowitz & Stegun 4.4.46), far below the 6° bins it feeds.
TEST(FastAcos, AgreesWithLibmWithinTheBound) {
  double worst = 0;
  for (int i = -200000; i <= 200000; ++i) {
    const double x = i / 200000.0;
    worst = std::max(worst, std::abs(detail::fast_acos(x) - std::acos(x)));
  }
  EXPECT_LT(worst, 2.5e-8);
  EXPECT_NEAR(detail::fast_acos(1.0), 0.0, 1e-12);
  EXPECT_NEAR(detail::fast_acos(-1.0), std::numbers::pi, 1e-12);
  EXPECT_NEAR(detail::fast_acos(1.5), 0.0, 1e-12);  // clamped, as the features' cosines are
}

}  // namespace
}  // namespace align3d
