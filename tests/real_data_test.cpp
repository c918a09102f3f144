// Real range scans (../shared/data/real/, its README): the Stanford dragon's neighbours registered
// from an unknown pose with align()'s defaults, each pose checked against the reference poses of
// truth.txt (world = T_k · scan_k, good to about 0.3 mm and a few hundredths of a degree). No
// generator made these scans: their noise is structured, their samplings differ, they have holes
// and no sensor position. The files are read in place; the tests fail, saying where the files
// should be, when they are missing (ALIGN3D_REAL_DATA_DIR, a CMake cache variable).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "align3d/align.hpp"
#include "align3d/find.hpp"
#include "align3d/io/point_cloud_io.hpp"
#include "align3d/plane/plane.hpp"
#include "align3d/stitch.hpp"
#include "test_util.hpp"

namespace align3d {
namespace {

namespace fs = std::filesystem;

const fs::path kDragon = fs::path(ALIGN3D_REAL_DATA_DIR) / "stanford-dragon";
const fs::path kKinect = fs::path(ALIGN3D_REAL_DATA_DIR) / "pcl-kinect";

// The dragon's directory, or a failure naming where it should be.
::testing::AssertionResult dragon_present() {
  if (fs::is_regular_file(kDragon / "truth.txt")) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "the real scans are missing: expected the Stanford dragon at " << kDragon
         << " (../shared/data/real/ beside the repository, or configure with "
            "-DALIGN3D_REAL_DATA_DIR=<dir holding stanford-dragon/>)";
}

// truth.txt: per line a file name and the 16 numbers of its world-from-scan pose, row-major.
std::map<int, Eigen::Isometry3d> dragon_truth() {
  std::map<int, Eigen::Isometry3d> poses;
  std::ifstream in(kDragon / "truth.txt");
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string name;
    Eigen::Matrix4d m;
    fields >> name;
    for (int k = 0; k < 16; ++k) fields >> m(k / 4, k % 4);
    const std::size_t from = name.find('_') + 1;
    poses[std::stoi(name.substr(from, name.find('.') - from))] = Eigen::Isometry3d(m);
  }
  return poses;
}

PointCloud dragon_scan(int angle) {
  return io::read_point_cloud(kDragon / ("dragonStandRight_" + std::to_string(angle) + ".ply"));
}

std::string warning_lines(const std::vector<Warning>& warnings) {
  std::string out;
  for (const Warning& w : warnings) out += w.code + ": " + w.message + "\n";
  return out;
}

struct DragonPair {
  int source, target;  // the scans' turntable angles (degrees)
};

// Neighbours 24° and 48° apart, both directions (their overlaps 0.55-0.8): each right to 0.5° and
// 1 mm at the source's centroid, and no warning (issue 55's target). Before the fit at the noise
// (icp/fit.hpp) five of six such right poses were warned high_rms.
TEST(RealScans, DragonNeighboursFromAnUnknownPoseAreRightAndUnwarned) {
  ASSERT_TRUE(dragon_present());
  const std::map<int, Eigen::Isometry3d> truth = dragon_truth();
  for (const DragonPair p : {DragonPair{24, 0}, DragonPair{0, 24}, DragonPair{192, 168},
                             DragonPair{0, 48}, DragonPair{312, 264}}) {
    SCOPED_TRACE(std::to_string(p.source) + " onto " + std::to_string(p.target));
    const PointCloud source = dragon_scan(p.source), target = dragon_scan(p.target);
    const Eigen::Isometry3d expected = truth.at(p.target).inverse() * truth.at(p.source);
    const AlignResult r = align(source, target);
    ASSERT_TRUE(r.success) << r.failure;
    const Eigen::Vector3d c = centroid(source);
    EXPECT_LT(test::rotation_error_deg(r.transformation, expected), 0.5);
    EXPECT_LT((r.transformation * c - expected * c).norm(), 1e-3);  // metres
    EXPECT_TRUE(r.warnings.empty()) << warning_lines(r.warnings);
  }
}

// Farther pairs, where the overlap falls to 0.3 and below and the dragon's own shapes repeat: every
// answer is right or warned, never silently wrong.
TEST(RealScans, DragonFarPairsAreRightOrWarned) {
  ASSERT_TRUE(dragon_present());
  const std::map<int, Eigen::Isometry3d> truth = dragon_truth();
  for (const DragonPair p : {DragonPair{96, 48}, DragonPair{72, 0}}) {
    SCOPED_TRACE(std::to_string(p.source) + " onto " + std::to_string(p.target));
    const PointCloud source = dragon_scan(p.source), target = dragon_scan(p.target);
    const Eigen::Isometry3d expected = truth.at(p.target).inverse() * truth.at(p.source);
    const AlignResult r = align(source, target);
    const Eigen::Vector3d c = centroid(source);
    const bool right = r.success && test::rotation_error_deg(r.transformation, expected) < 0.5 &&
                       (r.transformation * c - expected * c).norm() < 1e-3;
    EXPECT_TRUE(right || !r.warnings.empty() || !r.success)
        << "silently wrong: " << test::rotation_error_deg(r.transformation, expected) << "°";
  }
}

// Stitching scans whose files carry no sensor position (issue 56): the dragon's scans lie in the
// scanner's coordinates, whose origin is under or inside the statuette, so taking it for the
// sensor vetoed every right pair (free space) and turned the normals half inward; stitch places
// each sensor from the scan itself. Five neighbours in a shuffled order, every pose against the
// reference in the first scan's frame; the sensors reported as estimated.
TEST(RealScans, DragonScansWithoutSensorPositionsStitch) {
  ASSERT_TRUE(dragon_present());
  const std::map<int, Eigen::Isometry3d> truth = dragon_truth();
  const std::vector<int> angles = {216, 120, 168, 144, 192};
  std::vector<PointCloud> scans;
  for (int a : angles) scans.push_back(dragon_scan(a));
  StitchSettings s;
  s.threads = 2;
  const StitchResult r = stitch(scans, s);
  ASSERT_EQ(r.scans.size(), angles.size());
  for (std::size_t k = 0; k < angles.size(); ++k) {
    SCOPED_TRACE("scan " + std::to_string(angles[k]));
    const StitchScan& got = r.scans[k];
    const Eigen::Isometry3d expected = truth.at(angles[0]).inverse() * truth.at(angles[k]);
    const Eigen::Vector3d c = centroid(scans[k]);
    EXPECT_TRUE(got.connected);
    EXPECT_LT(test::rotation_error_deg(got.transformation, expected), 0.5);
    EXPECT_LT((got.transformation * c - expected * c).norm(), 1e-3);  // metres
    EXPECT_EQ(got.sensor, SensorSource::kEstimated);
    // The scanner looks along +z of its frame at the statuette (all 15 scans' normals face about
    // +z): the estimated sensor lies on that side of the scan.
    EXPECT_GT((got.viewpoint - c).normalized().z(), 0.5);
  }
  EXPECT_TRUE(r.warnings.empty()) << warning_lines(r.warnings);
}

// A part taught from a scan (issue 57): a box of PCL's first Kinect frame (two boxes on a table,
// 640 x 480, VIEWPOINT a half turn off the camera), cut out of the frame (its pixels in a window
// around it, more than 15 mm above the table's plane) and moved by a known pose, no normals.
struct TaughtBox {
  PointCloud points;        // moved
  Eigen::Isometry3d truth;  // in frame 0: scene ≈ truth · model
};
TaughtBox taught_box(const FindScene& frame0, int u0, int u1, int v0, int v1) {
  const Plane table = ransac_plane(frame0.cloud.positions, {0.01, 500, 1, 20000}).plane;
  const double camera_side = table.signed_distance(Eigen::Vector3d::Zero()) > 0 ? 1 : -1;
  TaughtBox box;
  for (std::size_t i = 0; i < frame0.cloud.size(); ++i) {
    const auto u = static_cast<int>(frame0.pixels[i] % 640),
               v = static_cast<int>(frame0.pixels[i] / 640);
    if (u >= u0 && u < u1 && v >= v0 && v < v1 &&
        camera_side * table.signed_distance(frame0.cloud.positions[i]) > 0.015)
      box.points.positions.push_back(frame0.cloud.positions[i]);
  }
  const Eigen::Isometry3d moved = Eigen::Translation3d(0.5, -0.2, 0.3) *
                                  Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, 1, 0.2).normalized());
  for (Eigen::Vector3d& p : box.points.positions) p = moved * p;
  box.truth = moved.inverse();
  return box;
}

const char* const kKinectFrames[] = {"frame_20121214T142255.814212.pcd",
                                     "frame_20121214T142256.068683.pcd",
                                     "frame_20121214T142256.332395.pcd"};

::testing::AssertionResult kinect_present() {
  if (fs::is_regular_file(kKinect / kKinectFrames[0])) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "the real Kinect frames are missing: expected them in " << kKinect
         << " (../shared/data/real/ beside the repository, or -DALIGN3D_REAL_DATA_DIR=<dir>)";
}

// The smaller box: find() takes it for a partial model and finds it once in frame 0, at the pose
// the cut undoes, and once in each later frame, on the box (the scene moves between frames: no
// exact truth there; the box stays within 0.05 m of where it was). The other box, the table and
// the room are the distractors; before the sensor's field (RangeImage::in_field) a face matched
// into the Kinect's blind border band of frame 1 was reported too.
TEST(RealScans, KinectBoxTaughtFromTheFrameIsFoundOnce) {
  ASSERT_TRUE(kinect_present());
  const FindScene frame0 = read_find_scene(kKinect / kKinectFrames[0]);
  const TaughtBox box = taught_box(frame0, 382, 520, 160, 330);
  ASSERT_GT(box.points.size(), 10000u);
  const PpfModel model = build_find_model(box.points, kFindVoxelFraction, 2);
  const Eigen::Vector3d c = centroid(box.points);
  FindSettings s;
  s.threads = 2;
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE(kKinectFrames[k]);
    const FindResult r =
        find(model, k == 0 ? frame0 : read_find_scene(kKinect / kKinectFrames[k]), s);
    EXPECT_TRUE(r.model_side.partial);
    EXPECT_TRUE(r.image.orientation_from_rays);
    ASSERT_EQ(r.instances.size(), 1u);
    const Eigen::Isometry3d& T = r.instances[0].T_scene_model;
    if (k == 0) {
      EXPECT_LT(test::rotation_error_deg(T, box.truth), 2.0);
      EXPECT_LT((T * c - box.truth * c).norm(), 0.005);  // metres
    } else {
      EXPECT_LT((T * c - box.truth * c).norm(), 0.05);
    }
  }
}

// The larger box (its front face 0.45 m, nearly a plane): in frames 0 and 2 nothing off the box is
// reported (frame 2 reported two faces matched into the room's walls where they leave the image or
// its blind band). Its true pose is not found yet (it scores about 0.57, its outline continued by
// the table where the teach-in was cut), nor is frame 1 free of a phantom (issue 57's note).
TEST(RealScans, KinectLargerBoxIsNotReportedOffTheBox) {
  ASSERT_TRUE(kinect_present());
  const FindScene frame0 = read_find_scene(kKinect / kKinectFrames[0]);
  const TaughtBox box = taught_box(frame0, 120, 380, 130, 330);
  const PpfModel model = build_find_model(box.points, kFindVoxelFraction, 2);
  const Eigen::Vector3d c = centroid(box.points);
  FindSettings s;
  s.threads = 2;
  for (int k : {0, 2}) {
    SCOPED_TRACE(kKinectFrames[k]);
    const FindResult r =
        find(model, k == 0 ? frame0 : read_find_scene(kKinect / kKinectFrames[k]), s);
    for (const FoundInstance& f : r.instances)
      EXPECT_LT((f.T_scene_model * c - box.truth * c).norm(), 0.05) << "score " << f.score;
  }
}

}  // namespace
}  // namespace align3d
