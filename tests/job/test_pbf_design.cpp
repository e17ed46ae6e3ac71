// A .vcad that is itself a TPMS sheet is what `trellis pbf` plans (its φ, c and box), not an
// envelope the configured lattice fills; other designs stay envelopes, with a warning when they
// hold a lattice of their own (the part would be the intersection of the two).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "support/temp_dir.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/file.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/job/job.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/slice/pbf_analysis.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

// Sign agreement of two fields at random points of a box a little larger than `box`.
std::size_t sign_mismatches(const Field& a, const Field& b, const BBox3& box, unsigned seed) {
  Evaluator ea(a), eb(b);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.1, 1.1);
  std::size_t bad = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec3 p{box.min.x + u(rng) * (box.max.x - box.min.x),
                 box.min.y + u(rng) * (box.max.y - box.min.y),
                 box.min.z + u(rng) * (box.max.z - box.min.z)};
    const double va = ea.value(p), vb = eb.value(p);
    if (std::abs(va) > 1e-9 && std::abs(vb) > 1e-9 && (va < 0) != (vb < 0)) ++bad;
  }
  return bad;
}

Field vcad(const std::string& text) {
  return parse_vcad(text, "test.vcad").field;
}

TEST(SplitSheet, ABoxedSheetIsItsLatticeAndItsBox) {
  for (const char* text : {"root((-1,-2,0),(2,1,1.5),(0.05,0.05,0.05)) { gyroid(1.5, 0.3); }",
                           "root((-2,-2,-2),(2,2,2),(0.05,0.05,0.05)) { intersection() { "
                           "schwarz_p(2, 0.2); sphere(1.6); } }",
                           "root((-2,-2,-2),(2,2,2),(0.05,0.05,0.05)) { intersection() { "
                           "sphere(1.6); diamond(2, \"0.1+0.05*z\"); } }"}) {
    SCOPED_TRACE(text);
    const Field design = vcad(text);
    const auto s = split_sheet(design);
    ASSERT_TRUE(s.has_value());
    EXPECT_TRUE(has_tpms(design));
    PbfDesign d;
    d.phi = s->phi;
    d.c = s->c;
    d.thickness = s->thickness;
    d.envelope = s->envelope;
    d.clip = s->boxes;
    EXPECT_EQ(d.clip.size(), 1u);
    EXPECT_EQ(sign_mismatches(design, d.part(), design.extent(), 7), 0u);
  }
}

TEST(SplitSheet, OtherDesignsAreNotSplit) {
  // A sheet in a union, two sheets, a transformed sheet, a network solid, no lattice at all.
  const char* lattice[] = {
      "root((-2,-2,-2),(2,2,2),(0.05,0.05,0.05)) { union() { gyroid(2, 0.3); sphere(0.5); } }",
      "root((-2,-2,-2),(2,2,2),(0.05,0.05,0.05)) { intersection() { gyroid(2, 0.3); gyroid(1, "
      "0.2); } }",
      "root((-2,-2,-2),(2,2,2),(0.05,0.05,0.05)) { rotate(0,0,30) { gyroid(2, 0.3); } }",
      "root((-2,-2,-2),(2,2,2),(0.05,0.05,0.05)) { gyroid(2); }"};
  for (const char* text : lattice) {
    SCOPED_TRACE(text);
    const Field design = vcad(text);
    EXPECT_FALSE(split_sheet(design).has_value());
    EXPECT_TRUE(has_tpms(design));
  }
  const Field solid = vcad("root((-2,-2,-2),(2,2,2),(0.05,0.05,0.05)) { sphere(1.5); }");
  EXPECT_FALSE(split_sheet(solid).has_value());
  EXPECT_FALSE(has_tpms(solid));
}

struct PbfRun {
  JobResult result;
  Diagnostics diag;
};

PbfRun run_pbf(const fs::path& dir, const std::string& name, const std::string& input,
               const std::vector<std::string>& sets) {
  const fs::path job_file = dir / (name + ".toml");
  std::ofstream(job_file) << "[job]\nroute = \"pbf\"\nname = \"" << name << "\"\n"
                          << (input.empty() ? "" : "input = \"" + input + "\"\n");
  std::vector<std::string> all = {"output.png=false", "scan.layer=0.05"};
  all.insert(all.end(), sets.begin(), sets.end());
  Job job = load_job(job_file.string(), (dir / name).string(), all);
  job.keep_toolpath = true;
  PbfRun r;
  r.result = run_job(job, r.diag);
  return r;
}

TEST(PbfDesign, ASheetDesignIsPlannedAsTheSameLatticeFromSettings) {
  const test::TempDir tmp("trellis_pbf_design");
  const fs::path dir = tmp.path();
  const std::string text = "root((-1,-1,-0.3),(1,1,0.3),(0.05,0.05,0.05)) { gyroid(2, 0.3); }\n";
  std::ofstream(dir / "sheet.vcad") << text;
  const PbfRun from_design = run_pbf(dir, "design", "sheet.vcad", {});
  const PbfRun from_settings =
      run_pbf(dir, "settings", "", {"pbf.cell=2", "pbf.c=0.3", "pbf.size=2,2,0.6"});
  ASSERT_TRUE(from_design.result.toolpath && from_settings.result.toolpath);
  // Nothing about the design itself: the one warning both give is the build's own (this thick
  // a sheet makes no contour vectors).
  for (const PbfRun* r : {&from_design, &from_settings})
    for (const auto& m : r->diag.messages()) EXPECT_EQ(m.kind, "pbf_no_contours") << m.text;
  EXPECT_EQ(from_design.diag.total(), from_settings.diag.total());
  // The same part, so the same build file (after the header's copy of the job).
  ASSERT_FALSE(from_design.result.files.empty());
  const auto geometry = [](const std::string& file) {
    const std::string text = read_file(file);
    const std::size_t at = text.find("$$DIMENSION");
    return at == std::string::npos ? std::string() : text.substr(at);
  };
  const std::string g = geometry(from_design.result.files.front());
  EXPECT_GT(g.size(), 2000u);
  EXPECT_EQ(g, geometry(from_settings.result.files.front()));
  // Every vector inside the design's sheet, and the sheet filled: this wall is thick, so it is
  // hatched, FR_a = D·ΣL/A is 0.85–1 on every layer (the default
  // 2.5 mm lattice cut by this one, the old reading of the design, leaves fragments).
  const LaserAnalysis a = analyze_laser_toolpath(*from_design.result.toolpath, vcad(text));
  ASSERT_GE(a.layers.size(), 10u);
  EXPECT_EQ(a.outside_vectors, 0u);
  for (const auto& L : a.layers) {
    if (L.area < 0.05) continue;
    EXPECT_GT(L.fr, 0.7) << "z " << L.z << " area " << L.area;
  }
}

TEST(PbfDesign, IgnoredLatticeSettingsAndLatticeEnvelopesAreNamed) {
  const test::TempDir tmp("trellis_pbf_design_warn");
  const fs::path dir = tmp.path();
  std::ofstream(dir / "sheet.vcad")
      << "root((-1.25,-1.25,-0.2),(1.25,1.25,0.2),(0.05,0.05,0.05)) { gyroid(2.5, 0.3); }\n";
  const PbfRun ignored = run_pbf(dir, "ignored", "sheet.vcad", {"pbf.cell=3"});
  ASSERT_EQ(ignored.diag.count("pbf.design_lattice"), 1u);
  EXPECT_NE(ignored.diag.messages().front().text.find("pbf.cell"), std::string::npos);
  // The report says where the lattice came from and carries the warning.
  const std::string* report = nullptr;
  for (const auto& f : ignored.result.files)
    if (f.ends_with(".json")) report = &f;
  ASSERT_NE(report, nullptr);
  const std::string json = read_file(*report);
  EXPECT_NE(json.find("\"lattice\": \"design sheet.vcad\""), std::string::npos);
  EXPECT_NE(json.find("\"kind\": \"pbf.design_lattice\""), std::string::npos);
  std::ofstream(dir / "mixed.vcad")
      << "root((-1.25,-1.25,-0.2),(1.25,1.25,0.2),(0.05,0.05,0.05)) { union() { gyroid(2.5, 0.3); "
         "sphere(0.4); } }\n";
  const PbfRun mixed = run_pbf(dir, "mixed", "mixed.vcad", {});
  EXPECT_EQ(mixed.diag.count("pbf.envelope_lattice"), 1u);
  const PbfRun named = run_pbf(dir, "named", "", {"pbf.envelope=" + (dir / "mixed.vcad").string()});
  EXPECT_EQ(named.diag.count("pbf.envelope_lattice"), 1u);
  std::ofstream(dir / "solid.vcad") << "root((-2,-2,-2),(2,2,2),(0.05,0.05,0.05)) { sphere(1); }\n";
  const PbfRun solid = run_pbf(dir, "solid", "solid.vcad", {"pbf.cell=1"});
  EXPECT_EQ(solid.diag.total(), 0u);
}

}  // namespace
