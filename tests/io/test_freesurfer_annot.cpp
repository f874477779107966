// FreeSurfer annotations: a file written by nibabel (the reference implementation of the format)
// reads back with its names, colours and labels; ours round-trip and nibabel reads them; broken
// files are refused with the file named.
#include <gtest/gtest.h>

#include <fstream>

#include "common/test_data.h"
#include "core/error.h"
#include "io/freesurfer_annot.h"

namespace {

namespace io = authalic::io;
using authalic::test::run_command;
using authalic::test::shell_quote;

bool have_nibabel() { return run_command("/usr/bin/python3 -c 'import nibabel'") == 0; }

TEST(FreeSurferAnnot, ReadsAFileWrittenByNibabel) {
  if (!have_nibabel()) {
    if (authalic::test::running_in_ci()) FAIL() << "CI=true but python3-nibabel is missing";
    GTEST_SKIP() << "python3-nibabel not installed";
  }
  const std::string path = authalic::test::temp_dir("annot_nibabel") + "/lh.test.annot";
  // 7 vertices: labels 0..2 and -1 (no label) on vertex 6; ctab rows r, g, b, a, value.
  const std::string script =
      "import numpy as np, nibabel as nib\n"
      "labels = np.array([0, 1, 1, 2, 2, 2, -1], dtype=np.int32)\n"
      "ctab = np.array([[25, 5, 25, 0, 0], [220, 180, 140, 0, 0], [160, 140, 180, 0, 0]], dtype=np.int32)\n"
      "nib.freesurfer.write_annot('" + path + "', labels, ctab, [b'unknown', b'posteriorcingulate', b'precuneus'], fill_ctab=True)\n";
  std::string out;
  ASSERT_EQ(run_command("/usr/bin/python3 -c " + shell_quote(script), &out), 0) << out;
  const io::Annotation a = io::read_freesurfer_annotation(path, 7);
  ASSERT_EQ(a.names, (std::vector<std::string>{"unknown", "posteriorcingulate", "precuneus"}));
  EXPECT_EQ(a.colours[2], (std::array<int, 4>{160, 140, 180, 0}));
  ASSERT_EQ(a.label.size(), 7);
  EXPECT_EQ(a.label(0), 0);
  EXPECT_EQ(a.label(2), 1);
  EXPECT_EQ(a.label(5), 2);
  // nibabel writes value 0 for -1, which matches no entry (unknown's colour is not 0): no label.
  EXPECT_EQ(a.label(6), -1);
}

TEST(FreeSurferAnnot, RoundTripsAndNibabelReadsOurs) {
  io::Annotation a;
  a.names = {"unknown", "precuneus", "cuneus"};
  a.colours = {{{25, 5, 25, 0}}, {{160, 140, 180, 0}}, {{220, 180, 140, 0}}};
  a.label.resize(5);
  a.label << 1, 2, 2, -1, 0;
  const std::string path = authalic::test::temp_dir("annot_round") + "/rh.aparc.annot";
  io::write_freesurfer_annotation(path, a);
  const io::Annotation b = io::read_freesurfer_annotation(path);
  EXPECT_EQ(b.names, a.names);
  EXPECT_EQ(b.colours, a.colours);
  EXPECT_EQ(b.label, a.label);
  if (!have_nibabel()) return;
  std::string out;
  ASSERT_EQ(run_command("/usr/bin/python3 -c " + shell_quote("import nibabel as nib\nl, c, n = nib.freesurfer.read_annot('" + path +
                                                    "')\nprint(list(l), [x.decode() for x in n])"),
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("[1, 2, 2, -1, 0] ['unknown', 'precuneus', 'cuneus']"), std::string::npos) << out;
}

TEST(FreeSurferAnnot, RefusesOtherSurfacesAndBrokenFiles) {
  io::Annotation a;
  a.names = {"precuneus"};
  a.colours = {{{160, 140, 180, 0}}};
  a.label = authalic::VectorXi::Zero(4);
  const std::string dir = authalic::test::temp_dir("annot_bad");
  io::write_freesurfer_annotation(dir + "/lh.aparc.annot", a);
  try {
    io::read_freesurfer_annotation(dir + "/lh.aparc.annot", 10);
    FAIL() << "vertex count mismatch accepted";
  } catch (const authalic::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("has 4 vertices but the surface has 10"), std::string::npos) << e.what();
  }
  std::ifstream in(dir + "/lh.aparc.annot", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(dir + "/cut.annot", std::ios::binary) << bytes.substr(0, bytes.size() - 10);
  EXPECT_THROW(io::read_freesurfer_annotation(dir + "/cut.annot"), authalic::InputError);
  std::ofstream(dir + "/none.annot", std::ios::binary) << bytes.substr(0, 4 + 4 * 8);  // no colour table
  try {
    io::read_freesurfer_annotation(dir + "/none.annot");
    FAIL() << "annotation without a colour table accepted";
  } catch (const authalic::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("none.annot"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no colour table"), std::string::npos) << e.what();
  }
}

}  // namespace
