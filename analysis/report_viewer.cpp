// The interactive 3D view inside the HTML report (issue 16): Niivue (npm @niivue/niivue, BSD-2,
// WebGL2), its UMD bundle inlined with the subject's pial surfaces and the z and PET overlays,
// so the page still opens without network. Rotate and zoom with the mouse; a slider sets the
// |z| threshold, a menu switches between z and PET. The bundle is installed (pinned by version
// and integrity in report_assets/package-lock.json) by scripts/install_deps.sh; without it, or
// when the surfaces would push the page past its 8 MB budget, the section says why instead.
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "analysis/render.h"
#include "analysis/report_figures.h"
#include "io/base64.h"

#ifndef AUTHALIC_NIIVUE_JS
#define AUTHALIC_NIIVUE_JS ""
#endif

namespace authalic::analysis {

namespace {

// The surfaces' share of the page (base64): the viewer is left out above it.
constexpr std::size_t kViewerDataBudget = 4'500'000;

std::string niivue_bundle() {
  const char* env = std::getenv("AUTHALIC_NIIVUE_JS");
  const std::string path = env && *env ? env : AUTHALIC_NIIVUE_JS;
  if (path.empty() || !std::filesystem::is_regular_file(path)) return "";
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  std::string js = s.str();
  // Inline in <script>: a literal "</script" would end the element early.
  for (std::size_t p = js.find("</script"); p != std::string::npos; p = js.find("</script", p)) js.replace(p, 2, "<\\/");
  return js;
}

template <class T>
std::string base64_of(const std::vector<T>& v) {
  std::vector<std::uint8_t> bytes(v.size() * sizeof(T));
  if (!v.empty()) std::memcpy(bytes.data(), v.data(), bytes.size());  // little-endian, as typed arrays read it
  return io::base64_encode(bytes);
}

// One hemisphere as JSON: pial vertices (float32), faces (uint32), z and PET per vertex (float32,
// 0 where undefined so it stays below any threshold).
std::string hemisphere_json(const ReportHemisphere& h) {
  const MatrixXi& F = h.surface_F.rows() > 0 ? h.surface_F : h.faces;
  const Eigen::Index n = h.surface_V.rows();
  std::vector<float> V(static_cast<std::size_t>(n) * 3), z(static_cast<std::size_t>(n), 0.f), pet(static_cast<std::size_t>(n), 0.f);
  std::vector<std::uint32_t> tris(static_cast<std::size_t>(F.rows()) * 3);
  for (Eigen::Index v = 0; v < n; ++v)
    for (int k = 0; k < 3; ++k) V[static_cast<std::size_t>(3 * v + k)] = static_cast<float>(h.surface_V(v, k));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) tris[static_cast<std::size_t>(3 * f + k)] = static_cast<std::uint32_t>(F(f, k));
  const VectorXd zv = report_vertex_z(h);
  for (Eigen::Index v = 0; v < n; ++v) {
    const bool cortex = h.element_of_vertex.size() != n || h.element_of_vertex(v) >= 0;
    if (cortex && v < zv.size() && std::isfinite(zv(v))) z[static_cast<std::size_t>(v)] = static_cast<float>(zv(v));
    if (cortex && v < h.pet.size() && std::isfinite(h.pet(v))) pet[static_cast<std::size_t>(v)] = static_cast<float>(h.pet(v));
  }
  return "{\"name\":\"" + h.name + "\",\"V\":\"" + base64_of(V) + "\",\"F\":\"" + base64_of(tris) + "\",\"z\":\"" + base64_of(z) +
         "\",\"pet\":\"" + base64_of(pet) + "\"}";
}

// The pictures' z colours (z_colouring: coolwarm over [-kReportZRange, kReportZRange]) at
// |z| = kReportZRange * i / 50, i = 0..50, for the viewer: {"hypo": [[r,g,b],...], "hyper": [...]}.
std::string z_colour_samples() {
  std::ostringstream s;
  for (const int sign : {-1, 1}) {
    s << (sign < 0 ? "{\"hypo\":[" : ",\"hyper\":[");
    for (int i = 0; i <= 50; ++i) {
      const Rgb c = colormap("coolwarm", 0.5 + 0.5 * sign * i / 50.0);
      s << (i ? "," : "") << "[" << int(c[0]) << "," << int(c[1]) << "," << int(c[2]) << "]";
    }
    s << "]";
  }
  s << "}";
  return s.str();
}

// Builds the scene, wires the controls, and reports in #nv-status whether WebGL drew anything
// (the count of non-background pixels, read back in the frame it was drawn).
const char* kViewerScript = R"JS(
(async function () {
  const status = document.getElementById('nv-status');
  try {
    const data = JSON.parse(document.getElementById('nv-data').textContent);
    const bytes = (s) => { const b = atob(s); const u = new Uint8Array(b.length); for (let i = 0; i < b.length; ++i) u[i] = b.charCodeAt(i); return u.buffer; };
    // Per-vertex layers as GIFTI (base64 little-endian float32, as embedded): a format Niivue
    // reads from a buffer without rescaling (its .curv reader normalises curvature to [0, 1]).
    const gifti = (b64, n) => new TextEncoder().encode('<?xml version="1.0" encoding="UTF-8"?><GIFTI Version="1.0" ' +
      'NumberOfDataArrays="1"><DataArray Intent="NIFTI_INTENT_NONE" DataType="NIFTI_TYPE_FLOAT32" ArrayIndexingOrder="RowMajorOrder" ' +
      'Dimensionality="1" Dim0="' + n + '" Encoding="Base64Binary" Endian="LittleEndian" ExternalFileName="" ExternalFileOffset="">' +
      '<Data>' + b64 + '</Data></DataArray></GIFTI>').buffer;
    const nv = new niivue.Niivue({ backColor: [1, 1, 1, 1], show3Dcrosshair: false, isColorbar: true });
    await nv.attachTo('nv-canvas');
    // The z colours of the report's pictures (coolwarm over +-zmax, sampled in data.zcolours at
    // |z| = zmax * i / (n - 1)) as Niivue colour maps from |z| = threshold (index 0) to zmax (255):
    // made again when the threshold moves, so that a z has one colour everywhere in the report
    // (Niivue's 'winter' ran dark blue at -2 to green at -5, the reverse of the pictures).
    const zmap = (side, threshold) => {
      const s = data.zcolours[side], key = 'authalic-' + side + '-' + threshold.toFixed(2);
      const cm = { R: [], G: [], B: [], A: [], I: [] };
      for (let i = 0; i < 32; ++i) {
        const x = (threshold + (data.zmax - threshold) * i / 31) / data.zmax * (s.length - 1);
        const j = Math.min(Math.floor(x), s.length - 2), f = x - j;
        ['R', 'G', 'B'].forEach((c, k) => cm[c].push(Math.round(s[j][k] + f * (s[j + 1][k] - s[j][k]))));
        cm.A.push(255);
        cm.I.push(Math.round(255 * i / 31));
      }
      nv.addColormap(key, cm);
      return key;
    };
    nv.setSliceType(nv.sliceTypeRender);
    const meshes = [];
    for (const h of data.hemispheres) {
      const F = new Uint32Array(bytes(h.F));
      const m = new niivue.NVMesh(new Float32Array(bytes(h.V)), F, h.name, new Uint8Array([200, 200, 200, 255]), 1, true, nv.gl);
      const n = m.pts.length / 3;
      const z = await niivue.NVMeshLoaders.readLayer(h.name + '_z.func.gii', gifti(h.z, n), m, 1, zmap('hyper', data.threshold),
                                                     zmap('hypo', data.threshold), true, data.threshold, data.zmax);
      const pet = await niivue.NVMeshLoaders.readLayer(h.name + '_pet.func.gii', gifti(h.pet, n), m, 0, 'viridis', '', false,
                                                       data.pet[0], data.pet[1]);
      // One colour bar (the first hemisphere's z) rather than one per layer and hemisphere.
      if (z) { z.colorbarVisible = meshes.length === 0; m.layers.push(z); }
      if (pet) { pet.colorbarVisible = false; m.layers.push(pet); }
      m.updateMesh(nv.gl);
      nv.addMesh(m);
      meshes.push(m);
    }
    const slider = document.getElementById('nv-threshold'), shown = document.getElementById('nv-threshold-value');
    const overlay = document.getElementById('nv-overlay');
    const apply = async () => {
      shown.textContent = Number(slider.value).toFixed(1);
      for (const m of meshes) {
        await nv.setMeshLayerProperty(m.id, 0, 'colormap', zmap('hyper', Number(slider.value)));
        await nv.setMeshLayerProperty(m.id, 0, 'colormapNegative', zmap('hypo', Number(slider.value)));
        await nv.setMeshLayerProperty(m.id, 0, 'cal_min', Number(slider.value));
        await nv.setMeshLayerProperty(m.id, 0, 'opacity', overlay.value === 'z' ? 1 : 0);
        await nv.setMeshLayerProperty(m.id, 1, 'opacity', overlay.value === 'pet' ? 1 : 0);
      }
    };
    slider.addEventListener('input', apply);
    overlay.addEventListener('change', apply);
    nv.drawScene();
    const gl = nv.gl, w = gl.drawingBufferWidth, h = gl.drawingBufferHeight, px = new Uint8Array(w * h * 4);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
    let drawn = 0, coloured = 0;
    const sum = [0, 0, 0];
    for (let i = 0; i < px.length; i += 4) {
      drawn += (px[i] < 250 || px[i + 1] < 250 || px[i + 2] < 250) ? 1 : 0;
      const above_colour_bar = i / 4 >= w * Math.floor(h / 5);  // rows from the bottom
      if (above_colour_bar && Math.max(px[i], px[i + 1], px[i + 2]) - Math.min(px[i], px[i + 1], px[i + 2]) > 40) {
        ++coloured;
        for (let k = 0; k < 3; ++k) sum[k] += px[i + k];
      }
    }
    status.textContent = 'interactive view ready: ' + drawn + ' pixels drawn';
    status.dataset.drawn = String(drawn);
    // The mean colour of the overlay on the surface (coloured pixels above the colour bar), for checks.
    if (coloured > 0) status.dataset.overlayColour = sum.map((s) => Math.round(s / coloured)).join(',');
  } catch (e) {
    status.textContent = 'interactive view unavailable: ' + e;
  }
})();
)JS";

}  // namespace

void viewer_section(std::ostringstream& out, const ReportData& d) {
  out << "<section id=\"viewer\">\n<h2>Interactive 3D view</h2>\n";
  const std::string js = niivue_bundle();
  std::string hemis;
  for (const ReportHemisphere& h : d.hemispheres) {
    if (h.surface_V.rows() == 0) continue;
    hemis += (hemis.empty() ? "" : ",") + hemisphere_json(h);
  }
  if (js.empty() || hemis.empty()) {
    out << "<p class=\"muted\">Not included: " << (js.empty() ? "the Niivue viewer is not installed (scripts/install_deps.sh)" : "no surface")
        << ". The pictures above show the same data.</p>\n</section>\n";
    return;
  }
  if (hemis.size() > kViewerDataBudget) {
    out << "<p class=\"muted\">Not included: the surfaces (" << hemis.size() / 1000000
        << " MB) would push this page past its 8 MB budget. The pictures above show the same data; the surfaces, PET"
        << (d.normative.present ? " and z" : "") << " open in Connectome Workbench (wb_view "
        << html_escape("sub-" + d.subject_id + "_workbench.spec") << ").</p>\n</section>\n";
    return;
  }
  std::vector<double> pet;
  for (const ReportHemisphere& h : d.hemispheres)
    for (Eigen::Index v = 0; v < h.pet.size(); ++v) pet.push_back(h.pet(v));
  const auto range = robust_range(Eigen::Map<const VectorXd>(pet.data(), static_cast<Eigen::Index>(pet.size())));
  std::ostringstream config;
  config << "{\"threshold\":" << d.normative.threshold << ",\"zmax\":" << kReportZRange << ",\"zcolours\":" << z_colour_samples()
         << ",\"pet\":[" << range.first << "," << range.second << "],\"hemispheres\":[" << hemis << "]}";
  out << "<p>Drag to rotate, scroll to zoom (Niivue, WebGL2). z in the colours of the pictures above: blue at or below "
         "\u2212threshold, darker for lower z; red at or above +threshold.</p>\n"
      << "<p><label>overlay <select id=\"nv-overlay\"><option value=\"z\">z</option><option value=\"pet\">PET</option></select></label>"
      << " &#160; <label>|z| threshold <input id=\"nv-threshold\" type=\"range\" min=\"0\" max=\"5\" step=\"0.1\" value=\""
      << d.normative.threshold << "\" /></label> <span id=\"nv-threshold-value\">" << d.normative.threshold
      << "</span> &#160; <span id=\"nv-status\" class=\"muted\">loading ...</span></p>\n"
      << "<div class=\"viewer\"><canvas id=\"nv-canvas\" width=\"960\" height=\"560\"></canvas></div>\n"
      << "<script type=\"application/json\" id=\"nv-data\">" << config.str() << "</script>\n"
      << "<script>" << js << "</script>\n<script>" << kViewerScript << "</script>\n</section>\n";
}

}  // namespace authalic::analysis
