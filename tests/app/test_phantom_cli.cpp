// `authalic phantom` and `authalic render` from the command line: outputs, JSON summary, errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "common/test_data.h"
#include "io/image_io.h"
#include "io/surface_io.h"

namespace {

namespace fs = std::filesystem;
using authalic::test::authalic_binary;
using authalic::test::run_command;

TEST(PhantomCli, WritesACohortAndASummary) {
  const std::string out = authalic::test::temp_dir("phantom_cli") + "/cohort";
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " phantom " + out +
                            " --synthetic --controls 2 --patients 1 --seed 9 --voxel-size 4 --json 2>/dev/null",
                        &output),
            0)
      << output;
  const auto j = nlohmann::json::parse(output);
  EXPECT_EQ(j.at("source"), "synthetic");
  EXPECT_EQ(j.at("controls"), 2);
  EXPECT_EQ(j.at("patients"), 1);
  EXPECT_DOUBLE_EQ(j.at("region_depth_fraction").get<double>(), 0.25);
  EXPECT_GT(j.at("region_area_mm2_per_hemisphere").get<double>(), 500.0);
  EXPECT_TRUE(fs::exists(out + "/cohort.csv"));
  EXPECT_TRUE(fs::exists(out + "/sub-patient01/sub-patient01_pet.nii.gz"));
  EXPECT_TRUE(fs::exists(out + "/truth/lesion.json"));
}

TEST(PhantomCli, BadArgumentsAreInputErrors) {
  std::string output;
  EXPECT_EQ(run_command(authalic_binary() + " phantom /tmp/x --controls -3", &output), 2) << output;
  EXPECT_EQ(run_command(authalic_binary() + " phantom /tmp/x --depth 1.5", &output), 2) << output;
  EXPECT_EQ(run_command(authalic_binary() + " phantom /tmp/x --controls 0 --patients 0 --synthetic", &output), 2) << output;
  EXPECT_NE(output.find("at least one subject"), std::string::npos) << output;
  EXPECT_EQ(run_command(authalic_binary() + " phantom /tmp/x --shared /nonexistent", &output), 2) << output;
  EXPECT_NE(output.find("/nonexistent"), std::string::npos) << output;
  // A file where the folder should be.
  const std::string dir = authalic::test::temp_dir("phantom_cli_file");
  std::ofstream(dir + "/occupied") << "x";
  EXPECT_EQ(run_command(authalic_binary() + " phantom " + dir + "/occupied --synthetic", &output), 2) << output;
  EXPECT_NE(output.find("occupied"), std::string::npos) << output;
}

TEST(RenderCli, DrawsFlatMapsSideBySide) {
  const std::string dir = authalic::test::temp_dir("render_cli");
  // The synthetic white surface seen from above (z dropped) is a flat "map" in mm, enough to
  // exercise the command; scaled into [0,1]^2 it is a map on the square.
  std::string output;
  ASSERT_EQ(run_command(authalic_binary() + " phantom " + dir + "/c --synthetic --controls 1 --patients 0 --voxel-size 6 -q", &output),
            0)
      << output;
  authalic::TriMesh flat = authalic::io::read_surface(dir + "/c/surf/lh.white").mesh;
  flat.V.col(2).setZero();
  const std::string mm = dir + "/flat_mm.surf.gii", uv = dir + "/flat_uv.surf.gii";
  authalic::io::write_surface(mm, flat);
  const Eigen::RowVector3d lo = flat.V.colwise().minCoeff(), hi = flat.V.colwise().maxCoeff();
  const double size = (hi - lo).head<2>().maxCoeff();
  for (Eigen::Index i = 0; i < flat.V.rows(); ++i) flat.V.row(i).head<2>() = (flat.V.row(i).head<2>() - lo.head<2>()) / size;
  authalic::io::write_surface(uv, flat);
  const std::string png = dir + "/maps.png";
  ASSERT_EQ(run_command(authalic_binary() + " render " + png + " " + uv + " " + uv + " --element-grid 4 --caption one --caption two --width 300 -q",
                        &output),
            0)
      << output;
  const authalic::io::RgbImage img = authalic::io::read_png(png);
  EXPECT_GT(img.width, 2 * 300);
  // --domain fit frames a map in mm: its plain gray fill covers much of the picture.
  const std::string fit = dir + "/fit.png";
  ASSERT_EQ(run_command(authalic_binary() + " render " + fit + " " + mm + " --domain fit --width 300 -q", &output), 0) << output;
  const authalic::io::RgbImage fitted = authalic::io::read_png(fit);
  long gray = 0;
  for (int y = 0; y < fitted.height; ++y) {
    for (int x = 0; x < fitted.width; ++x) gray += fitted.pixel(x, y)[0] == 210 && fitted.pixel(x, y)[2] == 210;
  }
  EXPECT_GT(gray, fitted.width * fitted.height / 3);
  // A map in mm drawn on the unit square, or a 3D surface, would be a blank or cropped picture:
  // both are refused, naming the option that draws them.
  const std::string refused = dir + "/refused.png";
  EXPECT_EQ(run_command(authalic_binary() + " render " + refused + " " + mm, &output), 2) << output;
  EXPECT_NE(output.find("outside the square [0,1]^2; for a flat surface in mm or a FreeSurfer flat patch use --domain fit"),
            std::string::npos)
      << output;
  EXPECT_EQ(run_command(authalic_binary() + " render " + refused + " " + dir + "/c/surf/lh.white --domain fit", &output), 2) << output;
  EXPECT_NE(output.find("not a flat map (z spans"), std::string::npos) << output;
  EXPECT_FALSE(fs::exists(refused));
  EXPECT_EQ(run_command(authalic_binary() + " render " + png + " /nonexistent.gii", &output), 2) << output;
  EXPECT_EQ(run_command(authalic_binary() + " render " + png + " " + uv + " --colormap jet", &output), 2) << output;
  EXPECT_NE(output.find("jet"), std::string::npos) << output;
}

}  // namespace
