// HTML report: a well-formed, self-contained page with every required section, embedded pictures
// that decode as PNG, escaped text, and deterministic bytes.
#include <gtest/gtest.h>

#include <cstdio>

#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>

#include "analysis/normative.h"
#include "analysis/report.h"
#include "io/base64.h"
#include "common/test_data.h"

namespace {

// The DOM of an HTML report after headless Chromium ran its scripts (software WebGL, 15 s of
// virtual time); returns Chromium's exit status.
int viewer_dom(const std::string& html, const std::string& profile, std::string* dom) {
  return authalic::test::run_command("timeout 120 chromium --headless --no-sandbox --disable-gpu --use-gl=angle "
                                     "--use-angle=swiftshader --enable-unsafe-swiftshader --disable-background-networking "
                                     "--user-data-dir=" + profile + " --virtual-time-budget=15000 --dump-dom file://" + html +
                                         " 2>/dev/null",
                                     dom);
}

namespace an = authalic::analysis;
namespace io = authalic::io;
using authalic::MatrixXd;
using authalic::MatrixXi;
using authalic::VectorXd;
using authalic::VectorXi;

// A tiny HTML/XML structure checker: every element closed in order (void elements must be written
// self-closed), attributes quoted. Collects ids, tag counts and <img> sources.
struct ParsedPage {
  bool ok = true;
  std::string error;
  std::map<std::string, int> tag_count;
  std::set<std::string> ids;
  std::vector<std::map<std::string, std::string>> images;
  std::vector<std::string> section_ids;  // in order
};

ParsedPage parse_page(const std::string& html) {
  ParsedPage page;
  std::vector<std::string> stack;
  std::size_t i = 0;
  auto fail = [&](const std::string& why) {
    page.ok = false;
    page.error = why + " at byte " + std::to_string(i);
  };
  while (page.ok) {
    const std::size_t lt = html.find('<', i);
    if (lt == std::string::npos) break;
    i = lt;
    if (html.compare(i, 9, "<!DOCTYPE") == 0) {
      i = html.find('>', i) + 1;
      continue;
    }
    const std::size_t gt = html.find('>', i);
    if (gt == std::string::npos) {
      fail("unterminated tag");
      break;
    }
    std::string tag = html.substr(i + 1, gt - i - 1);
    i = gt + 1;
    if (!tag.empty() && tag[0] == '/') {
      const std::string name = tag.substr(1);
      if (stack.empty() || stack.back() != name) {
        fail("</" + name + "> closes <" + (stack.empty() ? std::string("nothing") : stack.back()) + ">");
        break;
      }
      stack.pop_back();
      continue;
    }
    const bool self_closed = !tag.empty() && tag.back() == '/';
    if (self_closed) tag.pop_back();
    std::size_t p = 0;
    while (p < tag.size() && !std::isspace(static_cast<unsigned char>(tag[p]))) ++p;
    const std::string name = tag.substr(0, p);
    std::map<std::string, std::string> attrs;
    while (p < tag.size()) {
      while (p < tag.size() && std::isspace(static_cast<unsigned char>(tag[p]))) ++p;
      if (p >= tag.size()) break;
      const std::size_t eq = tag.find('=', p);
      if (eq == std::string::npos || eq + 1 >= tag.size() || tag[eq + 1] != '"') {
        fail("unquoted attribute in <" + name + ">");
        break;
      }
      const std::size_t end = tag.find('"', eq + 2);
      if (end == std::string::npos) {
        fail("unterminated attribute in <" + name + ">");
        break;
      }
      attrs[tag.substr(p, eq - p)] = tag.substr(eq + 2, end - eq - 2);
      p = end + 1;
    }
    page.tag_count[name]++;
    if (attrs.count("id")) page.ids.insert(attrs["id"]);
    if (name == "section") page.section_ids.push_back(attrs["id"]);
    if (name == "img") page.images.push_back(attrs);
    static const std::set<std::string> void_elements = {"meta", "img", "br", "hr", "link", "input"};
    if (void_elements.count(name) && !self_closed) {
      fail("<" + name + "> is not self-closed");
      break;
    }
    if (!self_closed) {
      stack.push_back(name);
      if (name == "style" || name == "script") {  // raw text up to the closing tag
        const std::size_t close = html.find("</" + name + ">", i);
        if (close == std::string::npos) {
          fail("unterminated <" + name + ">");
          break;
        }
        i = close;
      }
    }
  }
  if (page.ok && !stack.empty()) {
    page.ok = false;
    page.error = "unclosed <" + stack.back() + ">";
  }
  return page;
}

// A planar grid of n x n vertices on [0,1]^2 (flat map) and a bump in 3D (surface).
void grid_mesh(int n, MatrixXd* uv, MatrixXd* V, MatrixXi* F) {
  uv->resize(n * n, 2);
  V->resize(n * n, 3);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double u = double(i) / (n - 1), v = double(j) / (n - 1);
      uv->row(j * n + i) << u, v;
      V->row(j * n + i) << -40.0 - 10.0 * std::exp(-((u - 0.5) * (u - 0.5) + (v - 0.5) * (v - 0.5)) * 8), 100 * u - 50, 80 * v - 40;
    }
  }
  F->resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      F->row(f++) << a, b, d;
      F->row(f++) << a, d, c;
    }
  }
}

an::ReportData example_report(bool normative) {
  an::ReportData d;
  d.subject_id = "sub-<01>&";
  d.subject_info = {{"PET", "sub-01_pet.nii.gz"}, {"age", "67"}};
  d.parameters = {{"sampling", "normal projection, 10 mm inward"}, {"normalisation", "global cortical mean"}, {"K", "8"}};
  d.software = "authalic test";
  for (bool left : {true, false}) {
    an::ReportHemisphere h;
    h.name = left ? "left" : "right";
    h.left = left;
    grid_mesh(17, &h.flat_uv, &h.surface_V, &h.faces);
    if (!left) h.surface_V.col(0) *= -1;
    h.grid_cols = h.grid_rows = 8;
    h.pet = h.flat_uv.col(0).array() + 0.5;
    h.element_of_vertex.resize(h.flat_uv.rows());
    for (int v = 0; v < h.flat_uv.rows(); ++v) {
      const int col = std::min(7, static_cast<int>(h.flat_uv(v, 0) * 8)), row = std::min(7, static_cast<int>(h.flat_uv(v, 1) * 8));
      h.element_of_vertex(v) = row * 8 + col;
    }
    h.element_pet.assign(64, 1.0);
    if (normative) {
      h.element_z.assign(64, 0.0);
      h.element_z[3 * 8 + 4] = -3.5;
    }
    h.distortion = {{"flipped triangles", "0"}, {"element-area CV (K=8)", "0.004"}};
    d.hemispheres.push_back(h);
  }
  if (normative) {
    d.normative.present = true;
    d.normative.num_subjects = 20;
    d.normative.normalisation = "global cortical mean";
    d.normative.domain = "square, K = 8";
    an::ReportCluster c;
    c.id = 1;
    c.hemisphere = "left";
    c.sign = "hypo";
    c.num_elements = 1;
    c.area_mm2 = 250;
    c.peak_z = -3.5;
    c.mean_z = -3.5;
    c.peak_row = 3;
    c.peak_col = 4;
    c.region = "precuneus";
    c.region_fraction = 0.8;
    c.peak_region = "precuneus";
    d.clusters = {c, c};
    d.clusters[1].id = 2;
    d.clusters[1].hemisphere = "right";
    d.regions = {{"left", "parietal", "", 12, -1.25}, {"left", "parietal", "precuneus", 5, -2.5}};
    d.summary = "Hypometabolism in left precuneus and right precuneus (2 clusters, 500 mm2), peak z -3.5 in left precuneus.";
    d.region_method = "test parcellation";
  }
  d.subject_info.push_back({"tracer", "[18F]FDG"});
  d.quality = {{"left square map", "0 flipped triangles"}};
  return d;
}

TEST(Base64, Rfc4648Vectors) {
  auto enc = [](const std::string& s) { return io::base64_encode(std::vector<std::uint8_t>(s.begin(), s.end())); };
  EXPECT_EQ(enc(""), "");
  EXPECT_EQ(enc("f"), "Zg==");
  EXPECT_EQ(enc("fo"), "Zm8=");
  EXPECT_EQ(enc("foo"), "Zm9v");
  EXPECT_EQ(enc("foob"), "Zm9vYg==");
  EXPECT_EQ(enc("fooba"), "Zm9vYmE=");
  EXPECT_EQ(enc("foobar"), "Zm9vYmFy");
  const std::vector<std::uint8_t> bytes = {0, 255, 128, 7, 63, 200, 1};
  EXPECT_EQ(io::base64_decode(io::base64_encode(bytes)), bytes);
  EXPECT_THROW(io::base64_decode("Zm9"), std::invalid_argument);
  EXPECT_THROW(io::base64_decode("Zm9*"), std::invalid_argument);
  // Decoding every RFC vector back, padding only at the end (at most two), every byte value.
  auto dec = [](const std::string& s) { const auto b = io::base64_decode(s); return std::string(b.begin(), b.end()); };
  for (const std::string s : {"", "f", "fo", "foo", "foob", "fooba", "foobar"}) EXPECT_EQ(dec(enc(s)), s);
  for (const char* bad : {"Zg=v", "Z===", "====", "Zm9vZ=8=", "Zm=vYmFy", "Zm9v\nYmFy", "Zm9vYmF\xff"})
    EXPECT_THROW(io::base64_decode(bad), std::invalid_argument) << bad;
  std::vector<std::uint8_t> all(256 * 3 + 1);
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<std::uint8_t>(i * 7 + i / 256);
  EXPECT_EQ(io::base64_decode(io::base64_encode(all)), all);
  // The VTK reader's lenient prefix: stops at '=', at a non-digit, or at the bytes wanted.
  unsigned char buf[8] = {};
  EXPECT_EQ(io::base64_prefix("Zm9vYg==", buf, 8), 4u);
  EXPECT_EQ(std::string(reinterpret_cast<char*>(buf), 4), "foob");
  EXPECT_EQ(io::base64_prefix("Zm9vYmFy", buf, 2), 2u);
  EXPECT_EQ(io::base64_prefix("Zm9v\nYmFy", buf, 8), 3u);
}

TEST(Report, WellFormedSelfContainedWithAllSections) {
  const std::string html = an::report_html(example_report(true));
  ParsedPage page = parse_page(html);
  ASSERT_TRUE(page.ok) << page.error;
  EXPECT_EQ(page.tag_count["html"], 1);
  EXPECT_EQ(page.tag_count["head"], 1);
  EXPECT_EQ(page.tag_count["body"], 1);
  EXPECT_EQ(page.tag_count["title"], 1);
  for (const char* id : {"subject", "summary", "parameters", "flat-maps", "surface-views", "clusters", "regions", "normative",
                         "distortion"}) {
    EXPECT_TRUE(page.ids.count(id)) << "missing section " << id;
  }
  // The findings in words come before the pictures, with the disclaimer.
  EXPECT_LT(html.find("Hypometabolism in left precuneus"), html.find("id=\"surface-views\""));
  EXPECT_NE(html.find("Decision support, not a diagnosis"), std::string::npos);
  // Clusters and the regional table name regions for people.
  EXPECT_NE(html.find("<td>precuneus <span class=\"muted\">(80&#8201;%)</span></td>"), std::string::npos);
  EXPECT_NE(html.find("<strong>parietal</strong>"), std::string::npos);
  EXPECT_NE(html.find("\u22122.50"), std::string::npos);  // mean z, typeset minus
  EXPECT_NE(html.find("tracer</th><td>[18F]FDG"), std::string::npos);
  // Nothing is fetched from elsewhere: no link, no script or image by src, no url() in the CSS
  // (the inlined viewer's code mentions web pages in its comments; it loads nothing).
  for (const char* remote : {"src=\"http", "href=\"http", "url(http", "<script src", "import("})
    EXPECT_EQ(html.find(remote), std::string::npos) << remote;
  EXPECT_EQ(page.tag_count["link"], 0);
  EXPECT_LE(page.tag_count["script"], 3);  // the viewer: its data, the Niivue bundle and the scene, all inline
  // Text is escaped.
  EXPECT_NE(html.find("sub-&lt;01&gt;&amp;"), std::string::npos);
  EXPECT_EQ(html.find("sub-<01>"), std::string::npos);
  // The cluster table has a header and one row per cluster.
  const std::size_t clusters = html.find("id=\"clusters\"");
  const std::size_t end = html.find("</section>", clusters);
  int rows = 0;
  for (std::size_t p = html.find("<tr>", clusters); p < end; p = html.find("<tr>", p + 1)) ++rows;
  EXPECT_EQ(rows, 3);
  EXPECT_NE(html.find("control subjects (n)</th><td>20"), std::string::npos);
}

// The method text says how this comparison computed z (it was one fixed text: mean and SD,
// rescaled, "5-7 %", also for age-adjusted z and --no-rescale), and what the t distribution
// predicts for a healthy subject with this many controls.
TEST(Report, MethodTextDescribesTheComparisonMade) {
  an::ReportData d = example_report(true);
  d.normative.age_adjusted = false;
  d.normative.rescaled = false;
  d.normative.expected_abnormal_share = an::expected_abnormal_share(20, false, true, 2.0);
  std::string html = an::report_html(d);
  EXPECT_NE(html.find("z = (patient - mean of the controls) / SD"), std::string::npos);
  EXPECT_EQ(html.find("multiplied by the one factor"), std::string::npos);
  EXPECT_NE(html.find("with 20 controls, a healthy element still reaches |z| &gt;= 2.0 in about 6.0 %"), std::string::npos);
  d.normative.age_adjusted = true;
  d.normative.rescaled = true;
  d.normative.num_subjects = 6;
  d.normative.expected_abnormal_share = an::expected_abnormal_share(6, true, true, 2.0);
  html = an::report_html(d);
  EXPECT_NE(html.find("value expected at the patient"), std::string::npos);
  EXPECT_NE(html.find("multiplied by the one factor"), std::string::npos);
  EXPECT_NE(html.find("with 6 controls, a healthy element still reaches |z| &gt;= 2.0 in about 11.6 %"), std::string::npos);
}

TEST(Report, EmbeddedImagesDecodeAsPng) {
  const std::string html = an::report_html(example_report(true));
  ParsedPage page = parse_page(html);
  ASSERT_TRUE(page.ok) << page.error;
  // The eight standard views of z and of PET; per hemisphere the z and PET flat maps.
  EXPECT_EQ(page.images.size(), 6u);
  const std::string dir = authalic::test::temp_dir("report_images");
  int k = 0;
  for (const auto& img : page.images) {
    const std::string& src = img.at("src");
    const std::string prefix = "data:image/png;base64,";
    ASSERT_EQ(src.compare(0, prefix.size(), prefix), 0) << "image " << k << " is not an embedded PNG";
    const std::vector<std::uint8_t> png = io::base64_decode(src.substr(prefix.size()));
    ASSERT_GT(png.size(), 8u);
    EXPECT_EQ(png[0], 0x89);
    EXPECT_EQ(png[1], 'P');
    EXPECT_EQ(png[2], 'N');
    EXPECT_EQ(png[3], 'G');
    const std::string path = dir + "/img" + std::to_string(k++) + ".png";
    std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    const authalic::io::RgbImage decoded = authalic::io::read_png(path);
    EXPECT_EQ(std::to_string(decoded.width), img.at("width"));
    EXPECT_EQ(std::to_string(decoded.height), img.at("height"));
    EXPECT_FALSE(img.at("alt").empty());
  }
}

TEST(Report, WithoutNormativeSaysSoAndShowsPet) {
  const std::string html = an::report_html(example_report(false));
  ParsedPage page = parse_page(html);
  ASSERT_TRUE(page.ok) << page.error;
  EXPECT_NE(html.find("No normative reference was given"), std::string::npos);
  EXPECT_EQ(page.images.size(), 3u);  // the standard views of PET, the PET flat map per hemisphere
  for (const char* id : {"subject", "summary", "parameters", "flat-maps", "surface-views", "clusters", "normative", "distortion"}) {
    EXPECT_TRUE(page.ids.count(id)) << "missing section " << id;
  }
}

TEST(Report, DeterministicAndWrittenAtomically) {
  const an::ReportData d = example_report(true);
  const std::string a = an::report_html(d);
  EXPECT_EQ(a, an::report_html(d));
  const std::string path = authalic::test::temp_dir("report_write") + "/report.html";
  an::write_report(path, d);
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  EXPECT_EQ(s.str(), a);
}

// The PDF as poppler renders it: two A4 pages, neither blank, the z views' blue on page 1.
TEST(ReportPdf, TwoA4PagesThatPopplerRenders) {
  if (authalic::test::run_command("command -v pdftoppm") != 0) {
    if (authalic::test::running_in_ci()) FAIL() << "CI=true but pdftoppm (poppler-utils) is not installed";
    GTEST_SKIP() << "pdftoppm not installed";
  }
  const std::string dir = authalic::test::temp_dir("report_pdf");
  an::ReportData d = example_report(true);
  for (auto& h : d.hemispheres) h.element_z.assign(64, -4.0);  // everything abnormal: blue views
  an::write_report_pdf(dir + "/report.pdf", d);
  std::string out;
  ASSERT_EQ(authalic::test::run_command("pdfinfo " + dir + "/report.pdf", &out), 0) << out;
  const std::size_t pages = out.find("Pages:");
  ASSERT_NE(pages, std::string::npos) << out;
  EXPECT_EQ(std::stoi(out.substr(pages + 6)), 2) << out;
  EXPECT_NE(out.find("595.28 x 841.89 pts (A4)"), std::string::npos) << out;
  ASSERT_EQ(authalic::test::run_command("pdftoppm -r 50 -png " + dir + "/report.pdf " + dir + "/page", &out), 0) << out;
  for (const char* name : {"/page-1.png", "/page-2.png"}) {
    const io::RgbImage page = io::read_png(dir + name);
    EXPECT_NEAR(page.width, 595.28 * 50 / 72, 1.5);
    EXPECT_NEAR(page.height, 841.89 * 50 / 72, 1.5);
    long ink = 0, blue = 0;
    for (int y = 0; y < page.height; ++y)
      for (int x = 0; x < page.width; ++x) {
        const auto* p = page.pixel(x, y);
        ink += p[0] < 128 && p[1] < 128 && p[2] < 128;
        blue += p[2] > 150 && p[0] < 110 && p[1] < 130;
      }
    EXPECT_GT(ink, 500) << name << " is blank";
    if (std::string(name) == "/page-1.png") {
      EXPECT_GT(blue, 2000) << "no z view on page 1";
    }
  }
  // Same data, same bytes (no creation date).
  an::write_report_pdf(dir + "/again.pdf", d);
  EXPECT_EQ(authalic::test::run_command("cmp " + dir + "/report.pdf " + dir + "/again.pdf"), 0);
  // Many clusters: page 2 still ends with the whole disclaimer above its footer (16 clusters
  // pushed the disclaimer off the page and the footer over the quality rows).
  const an::ReportCluster first = d.clusters.front();
  d.clusters.assign(16, first);
  for (int i = 0; i < 16; ++i) d.clusters[static_cast<std::size_t>(i)].id = i + 1;
  for (const char* lobe : {"frontal", "temporal", "occipital", "insula", "cingulate", "limbic"})
    for (const char* side : {"left", "right"}) d.regions.push_back({side, lobe, "", 40, -0.5});
  for (int i = 0; i < 4; ++i)  // as many quality and processing rows as `run` writes, as long
    d.quality.push_back({"quality row " + std::to_string(i), "0.0 % of the cortex's vertices outside the PET's field of view, 0 without a value"});
  for (int i = 0; i < 6; ++i)
    d.parameters.push_back({"parameter " + std::to_string(i), "normal projection, inward (inverse normal), depth 10 mm, step 1.429 mm, 8 samples"});
  an::write_report_pdf(dir + "/many.pdf", d);
  ASSERT_EQ(authalic::test::run_command("pdftotext -f 2 -l 2 -bbox " + dir + "/many.pdf " + dir + "/many.html", &out), 0) << out;
  std::ifstream in(dir + "/many.html");
  const std::string words((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto y_of = [&](const std::string& word, const char* edge) {  // the last occurrence's yMin/yMax
    const std::size_t w = words.rfind(">" + word + "</word>");
    if (w == std::string::npos) return -1.0;
    const std::size_t a = words.rfind(std::string(edge) + "=\"", w);
    return std::stod(words.substr(a + std::string(edge).size() + 2));
  };
  const double disclaimer_end = y_of("findings.", "yMax"), footer = y_of("page", "yMin");
  ASSERT_GT(disclaimer_end, 0) << "the disclaimer is not on page 2";
  ASSERT_GT(footer, 0);
  EXPECT_LT(disclaimer_end, footer) << "the footer overprints the disclaimer";
  EXPECT_LT(disclaimer_end, 841.89 - 24) << "the disclaimer runs off the page";
}

// The interactive view as headless Chromium runs it, offline (WebGL2 through SwiftShader): the
// page's script reads the canvas back in the frame it drew and records how many pixels are not
// background; the static pictures are in the same page.
TEST(ReportViewer, ChromiumDrawsTheInteractiveViewOffline) {
  if (authalic::test::run_command("command -v chromium") != 0) {
    if (authalic::test::running_in_ci()) FAIL() << "CI=true but chromium is not installed";
    GTEST_SKIP() << "chromium not installed";
  }
  const std::string html_text = an::report_html(example_report(true));
  if (html_text.find("id=\"nv-canvas\"") == std::string::npos) {
    if (authalic::test::running_in_ci()) FAIL() << "CI=true but the Niivue bundle is not installed (scripts/install_deps.sh)";
    GTEST_SKIP() << "Niivue not installed (report_assets/node_modules)";
  }
  ASSERT_LT(html_text.size(), 8u * 1000 * 1000);
  const std::string dir = authalic::test::temp_dir("report_viewer");
  an::write_report(dir + "/report.html", example_report(true));
  std::string dom;
  ASSERT_EQ(viewer_dom(dir + "/report.html", dir + "/profile", &dom), 0);
  const std::size_t at = dom.find("data-drawn=\"");
  ASSERT_NE(at, std::string::npos) << dom.substr(dom.find("nv-status"), 300);
  EXPECT_GT(std::stol(dom.substr(at + 12)), 1000) << "the canvas is blank";
  ParsedPage page = parse_page(html_text);
  EXPECT_EQ(page.images.size(), 6u) << "the static pictures are there too";
}

// qa4_cli D8: the viewer coloured hypometabolism with Niivue's 'winter' (dark blue at -threshold,
// green at -5), the reverse of the pictures' coolwarm (light blue at -2, dark blue (59, 76, 192) at
// -5 and beyond). With z = -6 everywhere the overlay's pixels have the pictures' darkest blue (the
// lighting scales it): blue over twice green and red, red not near 0; 'winter' gave green.
TEST(ReportViewer, HypometabolismHasThePicturesColours) {
  if (authalic::test::run_command("command -v chromium") != 0) {
    if (authalic::test::running_in_ci()) FAIL() << "CI=true but chromium is not installed";
    GTEST_SKIP() << "chromium not installed";
  }
  an::ReportData d = example_report(true);
  for (auto& h : d.hemispheres) {
    h.element_z.assign(h.element_z.size(), -6.0);
    // A cylinder (the flat example is edge-on in the default view), on the right of the midline.
    for (Eigen::Index v = 0; v < h.surface_V.rows(); ++v) {
      const double u = h.flat_uv(v, 0), w = h.flat_uv(v, 1);
      h.surface_V.row(v) << (h.left ? -50 : 50) + 40 * std::cos(2 * M_PI * u), 40 * std::sin(2 * M_PI * u), 80 * w - 40;
    }
  }
  const std::string html_text = an::report_html(d);
  if (html_text.find("id=\"nv-canvas\"") == std::string::npos) {
    if (authalic::test::running_in_ci()) FAIL() << "CI=true but the Niivue bundle is not installed (scripts/install_deps.sh)";
    GTEST_SKIP() << "Niivue not installed (report_assets/node_modules)";
  }
  const std::string dir = authalic::test::temp_dir("report_viewer_colours");
  an::write_report(dir + "/report.html", d);
  std::string dom;
  ASSERT_EQ(viewer_dom(dir + "/report.html", dir + "/profile", &dom), 0);
  const std::size_t at = dom.find("data-overlay-colour=\"");
  ASSERT_NE(at, std::string::npos) << dom.substr(dom.find("nv-status"), 300);
  int r = 0, g = 0, b = 0;
  ASSERT_EQ(std::sscanf(dom.c_str() + at + 21, "%d,%d,%d", &r, &g, &b), 3) << dom.substr(at, 60);
  // (59, 76, 192) times the shading: green and red about 0.4 and 0.3 of blue.
  EXPECT_GT(b, 2 * g) << r << "," << g << "," << b;
  EXPECT_GT(b, 2 * r) << r << "," << g << "," << b;
  EXPECT_GT(5 * r, b) << r << "," << g << "," << b << ": the pictures' dark blue has red in it (59, 76, 192)";
  EXPECT_NE(html_text.find("blue at or below \u2212threshold, darker for lower z"), std::string::npos);
}

TEST(Report, RobustRangeIgnoresOutliersAndNan) {
  VectorXd v(102);
  for (int i = 0; i < 100; ++i) v(i) = i;
  v(100) = 1e9;
  v(101) = std::nan("");
  const auto [lo, hi] = an::robust_range(v);
  EXPECT_NEAR(lo, 2.0, 1.0);
  EXPECT_NEAR(hi, 98.0, 1.5);
}

}  // namespace
