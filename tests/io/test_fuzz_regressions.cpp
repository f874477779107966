// Inputs found by scripts/fuzz.sh (libFuzzer) that crashed a reader, kept as regression tests:
// each must now be refused with an InputError naming the file.
#include <gtest/gtest.h>

#include "io/io_test_util.h"
#include "io/surface_io.h"
#include "io/volume_io.h"

using namespace authalic;
using namespace authalic::io;
using namespace authalic::test;

namespace {
std::string write_case(const std::string& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir + "/" + name;
  write_bytes(path, bytes);
  return path;
}
}  // namespace

// gifticlib dereferenced NULL (SEGV inside its expat callback) for a <Value> outside <MD>;
// the reader now checks the XML structure against the GIFTI DTD before gifticlib parses it.
TEST(FuzzRegression, GiftiValueOutsideMdCrashedGifticlib) {
  const std::string dir = temp_dir("fuzz_gifti_value");
  const std::string bytes =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<!DOCTYPE GIFTI SYSTEM \"http://gifti.projects.nitrc.org/gifti.dtd\">\n"
    "<GIFTI Version=\"1.0\"  NumberOfDataArrays=\"1\">\n"
    "   <MetaData>\n"
    "      <MD>\n"
    "         <Name><![CDATA[generator]]></Name>\n"
    "         <Value><![CDATA[authalic]]></Value>\n"
    "      </MD>>\n"
    "         <Value><![CDATA[gifti library version 1.09, 28 June, 2010]]></Value>\n"
    "      </MD>\n"
    "   </MetaData>\n"
    "   <LabelTable>\n"
    "      <Label Key=\"0\" Red=\"1\" Green=\"0.25\" Blue=\"0.25\" Alpha=\"0\"><![CDATA[???]]></Label>\n"
    "      <Label Key=\"1\" Red=\"0.131316\" Green=\"0.976838\" Blue=\"0.391846\" Alpha=\"1\"><![CDATA[x]]></Label>\n"
    "      <Label Key=\"2\" Red=\"0.543713\" Green=\"0.0467889\" Blue=\"0.909498\" Alpha=\"1\"><![CDATA[y]]></Label>\n"
    "   </LabelTable>\n"
    "   <DataArray Intent=\"NIFTI_INTENT\xa1""\xad""ABEL\"\n"
    "              DataType=\"NIFTI_TYPE_INT32\"\n"
    "              ArrayIndexingOrder=\"RowMajorOrder\"\n"
    "              Dimensionality=\"1\"\n"
    "              Dim0=\"4\"\n"
    "              Encoding=\"GZipBase64Binary\"\n"
    "              Endian=\"LittleEndian\"\n"
    "              ExternalFileName=\"\"\n"
    "              ExternalFileOffset=\"\">\n"
    "      <MetaData/>\n"
    "      <Data>eJxjYGBgYIRiJiAGAAAsAAU=</Data>\n"
    "   </DataArray>\n"
    "</GIFTI>\n"
    "";
  const std::string path = write_case(dir, "crash1.label.gii", bytes);
  expect_input_error([&] { read_region_vertices(path); }, path, "<Value> is not allowed inside <MetaData>");
}

// A vertex index of -3e47 reached a double -> long long cast in the error message (undefined
// behaviour, UBSan); the message now prints the index without converting it to an integer.
TEST(FuzzRegression, LabelWithHugeNegativeIndexIsRefusedCleanly) {
  const std::string dir = temp_dir("fuzz_label_index");
  const std::string bytes = "#!ascii label\n1\n-" + std::string(48, '1') + "  0.0  0.0  0.0 0.0\n";
  const std::string path = write_case(dir, "crash2.label", bytes);
  expect_input_error([&] { read_region_vertices(path); }, path, "negative vertex index below -1000000000000000");
}

// gifticlib ended the whole process with exit() when text followed a CDATA section inside one
// element (here "<Name><![CDATA[a]]>zz</Name>"); the structure check now refuses it first.
TEST(FuzzRegression, GiftiTextAfterCdataEndedTheProcess) {
  const std::string dir = temp_dir("fuzz_gifti_cdata");
  const std::string bytes =
    "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
    "<GIFTI Version=\"1.0\" NumberOfDataArrays=\"1\">\n"
    "   <MetaData>\n"
    "      <MD>\n"
    "         <Name><![CDATA[generator]]>zz</Name>\n"
    "         <Value><![CDATA[authalic]]></Value>\n"
    "      </MD>\n"
    "   </MetaData>\n"
    "   <DataArray Intent=\"NIFTI_INTENT_SHAPE\" DataType=\"NIFTI_TYPE_FLOAT32\" ArrayIndexingOrder=\"RowMajorOrder\"\n"
    "              Dimensionality=\"1\" Dim0=\"1\" Encoding=\"ASCII\" Endian=\"LittleEndian\" ExternalFileName=\"\"\n"
    "              ExternalFileOffset=\"\">\n"
    "      <Data>1.5</Data>\n"
    "   </DataArray>\n"
    "</GIFTI>\n";
  const std::string path = write_case(dir, "crash3.func.gii", bytes);
  expect_input_error([&] { read_per_vertex(path, 1); }, path, "text after a CDATA section inside <Name>");
}

// nifti-clib 3.0 smashed its stack (abort) on a NIfTI-2 header whose sizeof_hdr reads
// little-endian while dim[0] and datatype only make sense big-endian; the reader now checks that
// the three agree before nifti-clib parses the header.
TEST(FuzzRegression, Nifti2HeaderOfMixedByteOrderCrashedNiftiClib) {
  const std::string dir = temp_dir("fuzz_nifti2_order");
  const std::string bytes(
      "\x1c\x02\x00\x00\x6e\x2b\x32\x00\x0d\x0a\x3f\x1a\x0a\x10\x00\x20\x00\x03\x00\x00\x00\x00\x00\x00\x00\x03\x00\x00\x00\x00\x00\x00"
      "\x00\x02\x00\x00\x00\x00\x00\x00\x00\x02\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x00\x00\x00"
      "\x00\x01\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\xf0\xbf\x00\x00\x00\x00\x00\x00\x00\x40\x00\x00\x00\x00\x00\x00\x00"
      "\x40\x00\x00\x00\x00\x00\x00\x00\x40\x00\x00\x00\x00\x00\x00\xf0\x3f\x00\x00\x00\x00\x00\x00\xf0\x3f\x00\x00\x00\x00\x00\x00\xf0"
      "\x3f\x00\x00\x00\x00\x00\x00\xf0\x3f\x20\x02\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\xf0\x3f\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x02\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x0a\x10\x00\x20\x00\x03\x00\x00\x00\x00\x00\x00\x00\x03\x00\x00\x00\x00\x00\x00\x00\x02"
      "\x00\x00\x00\x00\x00\x00\x00\x02\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x00\x00\x00\x00\x01"
      "\x00\x00\x00\x00\x00\x00\x00\x01\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\xf0\x3f\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x80\x56\x40\x00\x00\x00\x00\x00\x80\x5f\xc0\x00\x00\x00\x00\x00\x00\x52\xc0\x00\x00\x00\x00\x00\x00\x00\xc0\x00\x00\x00\x00"
      "\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x56\x40\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
      "\x00\x00\x00\x40\x00\x00\x00\x30\x41",
      553);
  const std::string path = write_case(dir, "mixed.nii", bytes);
  try {
    read_volume(path);
    FAIL() << "read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ": the header is inconsistent"), std::string::npos) << e.what();
  }
}
