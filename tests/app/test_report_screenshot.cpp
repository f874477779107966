// The HTML report as a browser shows it: scripts/screenshot_report.sh renders a report with headless
// Chromium (offline) and the screenshot must show the page, its pictures and its colours.
// Skips without Chromium locally; fails under CI=true (CI installs the Debian package `chromium`).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "analysis/report.h"
#include "common/test_data.h"
#include "io/image_io.h"

namespace {

namespace an = authalic::analysis;
namespace fs = std::filesystem;

bool have_chromium() {
  return authalic::test::run_command("command -v chromium || command -v chromium-browser || command -v google-chrome") == 0;
}

an::ReportData screenshot_report() {
  an::ReportData d;
  d.subject_id = "screenshot01";
  d.subject_info = {{"PET", "sub-screenshot01_pet.nii.gz"}};
  d.parameters = {{"elements", "16 x 16"}};
  an::ReportHemisphere h;
  const int n = 33;
  h.flat_uv.resize(n * n, 2);
  h.surface_V.resize(n * n, 3);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double u = double(i) / (n - 1), v = double(j) / (n - 1);
      h.flat_uv.row(j * n + i) << u, v;
      h.surface_V.row(j * n + i) << -40.0 - 8.0 * std::sin(6 * u) * std::sin(5 * v), 120 * u - 60, 90 * v - 40;
    }
  }
  h.faces.resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i;
      h.faces.row(f++) << a, a + 1, a + n + 1;
      h.faces.row(f++) << a, a + n + 1, a + n;
    }
  }
  h.grid_cols = h.grid_rows = 16;
  // z beyond the colour range everywhere: the coolwarm blue end must dominate the pictures.
  h.z = authalic::VectorXd::Constant(n * n, -6.0);
  h.pet = h.flat_uv.col(0);
  d.hemispheres.push_back(h);
  d.normative.present = true;
  d.normative.num_subjects = 20;
  return d;
}

TEST(ReportScreenshot, ChromiumRendersTheReportOffline) {
  if (!have_chromium()) {
    if (authalic::test::running_in_ci()) FAIL() << "CI=true but chromium is not installed (Debian package 'chromium')";
    GTEST_SKIP() << "chromium not installed; skipping the screenshot test";
  }
  const std::string dir = authalic::test::temp_dir("report_screenshot");
  const std::string html = dir + "/report.html", png = dir + "/shot.png";
  an::write_report(html, screenshot_report());
  const std::string script = std::string(AUTHALIC_SOURCE_DIR) + "/scripts/screenshot_report.sh";
  std::string output;
  ASSERT_EQ(authalic::test::run_command(script + " " + html + " " + png + " 1200 2000", &output), 0) << output;
  ASSERT_TRUE(fs::exists(png)) << output;
  const authalic::io::RgbImage shot = authalic::io::read_png(png);
  EXPECT_EQ(shot.width, 1200);
  EXPECT_EQ(shot.height, 2000);
  // The page is drawn (dark text on white) and its embedded pictures are decoded by the browser:
  // the coolwarm blue end (z = -4) covers a large area.
  long dark = 0, blue = 0;
  for (int y = 0; y < shot.height; ++y) {
    for (int x = 0; x < shot.width; ++x) {
      const auto* p = shot.pixel(x, y);
      dark += p[0] < 80 && p[1] < 80 && p[2] < 80;
      blue += std::abs(p[0] - 59) <= 12 && std::abs(p[1] - 76) <= 12 && std::abs(p[2] - 192) <= 12;
    }
  }
  EXPECT_GT(dark, 2000) << "no text on the page";
  EXPECT_GT(blue, 50000) << "the embedded z maps were not displayed";
}

TEST(ReportScreenshot, ScriptRejectsAMissingReport) {
  const std::string script = std::string(AUTHALIC_SOURCE_DIR) + "/scripts/screenshot_report.sh";
  std::string output;
  EXPECT_EQ(authalic::test::run_command(script + " /nonexistent/report.html /tmp/x.png", &output), 2);
  EXPECT_NE(output.find("no such file"), std::string::npos) << output;
  EXPECT_EQ(authalic::test::run_command(script, &output), 2);
  EXPECT_NE(output.find("usage"), std::string::npos) << output;
}

}  // namespace
