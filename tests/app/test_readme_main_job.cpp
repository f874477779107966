// The README's first command ends with the main job (after its last "&&"). This test runs that
// part verbatim from the repository root and checks that the report it promises appears, so the
// README cannot drift from what the program does.
#include <gtest/gtest.h>

#include <iterator>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
// GCC 12 warns inside libstdc++'s <regex> (an std::function member of a regex state "may be used
// uninitialized") when the sanitizer build instruments it: a false positive in the library's
// code, silenced for that header only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <regex>
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
#include <sstream>

#include "common/test_data.h"
#include "core/mesh.h"
#include "io/surface_formats.h"
#include "io/surface_io.h"

namespace fs = std::filesystem;

namespace {

std::vector<std::string> first_code_block(const std::string& readme) {
  std::ifstream in(readme);
  std::string line;
  std::vector<std::string> lines;
  int fences = 0;
  while (std::getline(in, line)) {
    if (line.rfind("```", 0) == 0) {
      if (++fences == 2) break;
      continue;
    }
    if (fences == 1) lines.push_back(line);
  }
  return lines;
}

}  // namespace

TEST(Readme, FirstCodeBlockHasExactlyTwoCommands) {
  const auto lines = first_code_block(std::string(AUTHALIC_SOURCE_DIR) + "/README.md");
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[0].find("&&"), std::string::npos) << "line 1 must be SETUP && MAIN_JOB";
  EXPECT_NE(lines[0].find("build/authalic run"), std::string::npos) << "the main job is the clinician pipeline";
}

TEST(Readme, MainJobRunsVerbatimAndWritesTheReport) {
  const auto lines = first_code_block(std::string(AUTHALIC_SOURCE_DIR) + "/README.md");
  ASSERT_EQ(lines.size(), 2u);
  const std::string main_job = lines[0].substr(lines[0].rfind("&&") + 2);
  // The report folder the job promises: --out DIR and --id ID -> DIR/sub-ID/sub-ID_report.html.
  std::smatch out, id;
  ASSERT_TRUE(std::regex_search(main_job, out, std::regex("--out\\s+(\\S+)")));
  ASSERT_TRUE(std::regex_search(main_job, id, std::regex("--id\\s+(\\S+)")));
  const fs::path root(AUTHALIC_SOURCE_DIR);
  // The job as written, run from the source tree with the binary under test (so a sanitizer build
  // tests itself, not the Release build/authalic) into a fresh --out.
  std::string job = main_job;
  const std::string exe = "build/authalic";
  ASSERT_NE(job.find(exe), std::string::npos);
  job.replace(job.find(exe), exe.size(), authalic::test::authalic_binary());
  const fs::path out_root = authalic::test::temp_dir("readme_main_job");
  job = std::regex_replace(job, std::regex("--out\\s+\\S+"), "--out '" + out_root.string() + "'");
  const fs::path report = out_root / ("sub-" + id[1].str()) / ("sub-" + id[1].str() + "_report.html");
  std::string output;
  const int rc = authalic::test::run_command("cd '" + root.string() + "' && " + job + " --quiet", &output);
  ASSERT_EQ(rc, 0) << output;
  ASSERT_TRUE(fs::exists(report)) << report;
  std::ifstream in(report);
  std::stringstream html;
  html << in.rdbuf();
  EXPECT_NE(html.str().find("<html"), std::string::npos);
  EXPECT_NE(html.str().find("data:image/png;base64,"), std::string::npos) << "pictures are embedded";
  EXPECT_NE(html.str().find("id=\"clusters\""), std::string::npos) << "the sample run compares with the reference";
  // Issue 16: clusters named by region (the sample's generated aparc.annot beside the cortex
  // labels), the findings in words, and the PDF beside the HTML.
  EXPECT_NE(html.str().find("Hypometabolism in left precuneus"), std::string::npos) << "the sample's clusters are named by region";
  EXPECT_TRUE(fs::exists(report.parent_path() / ("sub-" + id[1].str() + "_report.pdf")));
  // Quality flags: each map's element CV beside the limit its acceptance applied (on the sample's
  // coarse meshes looser than 0.01: 3 x 0.1 / sqrt(faces per element), core/metrics.h).
  const std::string page = html.str();
  int rows = 0;
  for (std::size_t at = page.find("square map</"); at != std::string::npos; at = page.find("square map</", at + 1)) {
    const std::size_t cell = page.find("<td>", at);
    ASSERT_NE(cell, std::string::npos);
    double cv = -1, limit = -1;
    const std::string text = page.substr(cell + 4, 200);
    if (std::sscanf(text.c_str(), "0 flipped triangles, element-area CV %lf at 32x32 (accepted: 0 flips, CV &lt;= %lf at 32x32)", &cv,
                    &limit) != 2)
      continue;  // the map's name elsewhere on the page
    ++rows;
    EXPECT_LE(cv, limit);
    EXPECT_GT(limit, 0.01);
  }
  EXPECT_EQ(rows, 2) << "one quality row per hemisphere";

  // Provenance (issue 15 items 5 and 9): the output folder is a BIDS derivative dataset, and each
  // sidecar records the command line as run and the inputs by the path given, with checksums.
  std::ifstream dd(out_root / "dataset_description.json");
  ASSERT_TRUE(dd.good());
  const auto d = nlohmann::json::parse(dd);
  EXPECT_EQ(d.at("DatasetType"), "derivative");
  EXPECT_FALSE(d.at("BIDSVersion").get<std::string>().empty());
  EXPECT_EQ(d.at("GeneratedBy").at(0).at("Name"), "authalic");
  std::ifstream sc(out_root / ("sub-" + id[1].str()) / ("sub-" + id[1].str() + "_hemi-L_desc-elements_zscore.json"));
  ASSERT_TRUE(sc.good());
  const auto j = nlohmann::json::parse(sc);
  EXPECT_NE(j.at("command_line").get<std::string>().find(authalic::test::authalic_binary() + " run --id " + id[1].str()), std::string::npos) << j.dump(1);
  std::smatch pet;
  ASSERT_TRUE(std::regex_search(main_job, pet, std::regex("--pet\\s+(\\S+)")));
  EXPECT_EQ(j.at("inputs").at("pet").at("path"), pet[1].str());
  EXPECT_EQ(j.at("inputs").at("pet").at("sha256").get<std::string>().size(), 64u);
  EXPECT_EQ(j.at("parameters").at("z_age_adjusted"), true);

  // Issue 15 item 6: beside the HTML, the clusters as TSV (with a sidecar describing its columns),
  // and per hemisphere the per-vertex z and element label, on the input's vertices.
  const fs::path subject = out_root / ("sub-" + id[1].str());
  const std::string stem = "sub-" + id[1].str();
  std::ifstream tsv(subject / (stem + "_clusters.tsv"));
  std::string header, first;
  ASSERT_TRUE(std::getline(tsv, header));
  EXPECT_EQ(header, "cluster\themisphere\tdirection\telements\tarea_mm2\tpeak_z\tmean_z\tpeak_row\tpeak_col\tpeak_x_mm\tpeak_y_mm\tpeak_z_mm"
                    "\tmass\tcontrols_as_large\tp_controls");
  ASSERT_TRUE(std::getline(tsv, first)) << "the sample patient has clusters";
  EXPECT_EQ(first.rfind("1\t", 0), 0u) << first;
  // The controls' chance clusters (leave-one-out, 20 controls): the planted region, in both
  // hemispheres, beats every control (p = 1/21); the patient's other clusters do not.
  std::vector<std::string> significant;
  int clusters = 0;
  for (std::string line = first; !line.empty(); line.clear(), std::getline(tsv, line)) {
    std::vector<std::string> cell;
    std::stringstream fields(line);
    for (std::string c; std::getline(fields, c, '\t');) cell.push_back(c);
    ASSERT_EQ(cell.size(), 15u) << line;
    ++clusters;
    const double p = std::stod(cell[14]);
    EXPECT_NEAR(p, (1.0 + std::stoi(cell[13])) / 21, 1e-5) << line;
    if (p < 0.05) significant.push_back(cell[1] + " " + cell[2]);
  }
  EXPECT_EQ(significant, (std::vector<std::string>{"left hypo", "right hypo"})) << clusters << " clusters";
  EXPECT_NE(html.str().find("against chance clusters in the 20 controls: 2 of the "), std::string::npos);
  EXPECT_NE(html.str().find("clusters (left precuneus and right cuneus) are larger than in every control (p = 0.048)"), std::string::npos);
  int bold_rows = 0;
  for (std::size_t at = page.find("<tr class=\"beyond\">"); at != std::string::npos; at = page.find("<tr class=\"beyond\">", at + 1)) ++bold_rows;
  EXPECT_EQ(bold_rows, 2) << "the cluster table shows the two clusters beyond chance in bold";
  std::ifstream tsv_sidecar(subject / (stem + "_clusters.json"));
  EXPECT_EQ(nlohmann::json::parse(tsv_sidecar).at("area_mm2").at("Units"), "mm^2");
  std::smatch white;
  ASSERT_TRUE(std::regex_search(main_job, white, std::regex("--lh-white\\s+(\\S+)")));
  const int nv = authalic::io::read_surface((root / white[1].str()).string()).mesh.num_vertices();
  const authalic::VectorXd z = authalic::io::read_per_vertex((subject / (stem + "_hemi-L_zscore.func.gii")).string(), nv);
  EXPECT_LT(z.array().isNaN().select(0.0, z.array()).minCoeff(), -2.0) << "the planted region is hypometabolic";
  // QA 4 item 10: the per-vertex z says it is a z-score, as the element z image does.
  EXPECT_EQ(authalic::io::detail::read_gifti((subject / (stem + "_hemi-L_zscore.func.gii")).string()).column_intents,
            std::vector<int>{5})
      << "NIFTI_INTENT_ZSCORE";
  const authalic::VectorXd labels = authalic::io::read_per_vertex((subject / (stem + "_hemi-L_desc-elements_dseg.label.gii")).string(), nv);
  EXPECT_GT(labels.maxCoeff(), 1000.0);  // element ids + 1 up to K^2 = 1024

  // Issue 15 item 5: every file is named sub-<id>[_hemi-L|R][_<key>-<value>...]_<suffix>.<ext>
  // (a BIDS suffix on every one), and every table has a JSON sidecar giving each column's units.
  const std::regex bids("sub-" + id[1].str() + "(_hemi-[LR])?(_[a-z]+-[A-Za-z0-9]+)*_[A-Za-z0-9]+\\.[a-z][a-z.]*");
  int files = 0;
  for (const auto& e : fs::directory_iterator(subject)) {
    const std::string name = e.path().filename().string();
    EXPECT_TRUE(std::regex_match(name, bids)) << name << " has no BIDS suffix";
    ++files;
    if (e.path().extension() == ".tsv") {
      std::ifstream side(subject / (e.path().stem().string() + ".json"));
      ASSERT_TRUE(side.good()) << name << " has no sidecar";
      const auto js = nlohmann::json::parse(side);
      const auto& columns = js.contains("columns") ? js.at("columns") : js;
      EXPECT_TRUE(columns.contains("area_mm2") && columns.at("area_mm2").at("Units") == "mm^2") << name << ": " << js.dump(1);
    }
  }
  EXPECT_GE(files, 40);
  EXPECT_TRUE(fs::exists(subject / (stem + "_elements.tsv")));
  // The rectangle part records where the hemispheres meet (issue 19: the seam is w_L, not x = 1),
  // in the file's own units, mm (QA 4 item 6: it said w_L in rectangle units in this mm file).
  const auto rect_part = authalic::io::read_surface((subject / (stem + "_hemi-L_space-authalicrect_flat.surf.gii")).string());
  EXPECT_EQ(rect_part.metadata.count("authalic_seam_x"), 0u);
  const double seam_mm = std::stod(rect_part.metadata.at("authalic_seam_x_mm"));
  // The left part is [0, w_L] x [0, 1] scaled by s: its height is s, its width w_L s = the seam in mm.
  const double s = rect_part.mesh.V.col(1).maxCoeff() - rect_part.mesh.V.col(1).minCoeff();
  EXPECT_GT(seam_mm / s, 0.5);
  EXPECT_LT(seam_mm / s, 1.5);
  EXPECT_NEAR(rect_part.mesh.V.col(0).maxCoeff(), seam_mm, 1e-4 * s) << "the left part spans [0, w_L] x s mm";
  EXPECT_NEAR(authalic::face_areas(rect_part.mesh.V, rect_part.mesh.F).sum(), seam_mm * s, 0.01 * seam_mm * s);
  EXPECT_TRUE(fs::exists(subject / (stem + "_log.txt")));

  // Issue 15 item 7: a Workbench spec per subject names the surfaces and the per-vertex files on
  // them; wb_command reads it, and every file it lists opens in wb_command with the structure the
  // spec gives it and, per-vertex, the surface's vertex count.
  const authalic::io::Surface input_white = authalic::io::read_surface((root / white[1].str()).string());
  const authalic::io::Surface written_white = authalic::io::read_surface((subject / (stem + "_hemi-L_white.surf.gii")).string());
  ASSERT_EQ(written_white.mesh.num_vertices(), nv);
  const Eigen::Vector4d v0 = input_white.to_scanner * input_white.mesh.V.row(0).transpose().homogeneous();
  EXPECT_LT((written_white.mesh.V.row(0).transpose() - v0.head<3>()).norm(), 1e-3) << "written in scanner RAS";
  const fs::path spec_path = subject / (stem + "_workbench.spec");
  ASSERT_TRUE(fs::exists(spec_path));
  if (authalic::test::run_command("command -v wb_command > /dev/null 2>&1") != 0) {
    if (authalic::test::running_in_ci()) FAIL() << "CI=true but wb_command (connectome-workbench) is missing";
    return;
  }
  std::string info;
  ASSERT_EQ(authalic::test::run_command("wb_command -file-information '" + spec_path.string() + "'", &info), 0) << info;
  EXPECT_NE(info.find("Specification"), std::string::npos) << info;
  std::ifstream spec_in(spec_path);
  const std::string spec((std::istreambuf_iterator<char>(spec_in)), std::istreambuf_iterator<char>());
  const std::regex entry("Structure=\"(\\w+)\" DataFileType=\"(\\w+)\" Selected=\"true\">\\s*(\\S+)\\s*</DataFile>");
  int entries = 0, metrics = 0, surfaces = 0;
  for (auto it = std::sregex_iterator(spec.begin(), spec.end(), entry); it != std::sregex_iterator(); ++it) {
    const std::string structure = (*it)[1], type = (*it)[2], file = (*it)[3];
    ++entries;
    metrics += type == "METRIC";
    surfaces += type == "SURFACE";
    EXPECT_NE(info.find(file), std::string::npos) << "wb_command lists " << file << "\n" << info;
    std::string file_info;
    ASSERT_EQ(authalic::test::run_command("wb_command -file-information '" + (subject / file).string() + "'", &file_info), 0) << file_info;
    EXPECT_NE(file_info.find(structure), std::string::npos) << file << "\n" << file_info;
    if (type != "SURFACE") {
      EXPECT_TRUE(std::regex_search(file_info, std::regex("Number of Vertices:\\s+" + std::to_string(nv) + "\\n"))) << file_info;
    }
  }
  // Per hemisphere: white, pial, the two flat maps (the sample's have the surface's vertices),
  // PET, z and elements.
  EXPECT_EQ(entries, 14) << spec;
  EXPECT_EQ(surfaces, 8) << spec;
  EXPECT_EQ(metrics, 4) << spec;
}
