// The irgrid command line: exit codes, messages on stderr, and the files it writes.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "irgrid/accelerator.h"
#include "irgrid/system.h"

namespace {

namespace fs = std::filesystem;

struct Result {
  int code;
  std::string out, err;
};

/// One directory per test process for the runs' output, removed when the process exits (ctest
/// runs every test in a process of its own).
fs::path scratch_dir() {
  static const struct Scratch {
    fs::path dir = fs::temp_directory_path() / ("irgrid_test_cli_" + std::to_string(::getpid()));
    Scratch() { fs::create_directories(dir); }
    ~Scratch() {
      std::error_code ignored;
      fs::remove_all(dir, ignored);
    }
  } scratch;
  return scratch.dir;
}

std::string read_text(const fs::path& path) {
  std::ifstream file(path);
  std::stringstream text;
  text << file.rdbuf();
  return text.str();
}

/// Runs the irgrid binary with `args` (a shell fragment), capturing stdout and stderr.
Result run(const std::string& args) {
  const auto dir = scratch_dir();
  const std::string command = std::string(IRGRID_CLI_PATH) + " " + args + " >" +
                              (dir / "stdout").string() + " 2>" + (dir / "stderr").string();
  const int status = std::system(command.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_text(dir / "stdout"),
          read_text(dir / "stderr")};
}

/// A run with `--json FILE` appended (FILE in the scratch directory), and the JSON it wrote
/// (null when the run failed).
struct JsonResult {
  Result result;
  nlohmann::json json;
};

JsonResult run_json(const std::string& args, const std::string& file) {
  const auto path = (scratch_dir() / file).string();
  JsonResult r{run(args + " --json " + path), nullptr};
  if (r.result.code == 0) r.json = nlohmann::json::parse(read_text(path));
  return r;
}

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string(IRGRID_CLI_PATH).empty()) GTEST_SKIP() << "the CLI is not built";
  }
  fs::path dir = scratch_dir();
};

TEST_F(Cli, InfoPrintsVersionBackendsAndBuiltinScenes) {
  const auto r = run("info");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find(std::string("irgrid ") + irgrid::version()), std::string::npos);
  EXPECT_NE(r.out.find("backends:"), std::string::npos);
  EXPECT_NE(r.out.find("builtin:hairball"), std::string::npos);
}

TEST_F(Cli, InfoNamesTheCpuWalk) {
  const auto chosen = run("info --json");
  ASSERT_EQ(chosen.code, 0) << chosen.err;
  const auto walk = nlohmann::json::parse(chosen.out)["cpu_walk"].get<std::string>();
  EXPECT_TRUE(walk == "avx512" || walk == "avx2" || walk == "scalar") << walk;
  EXPECT_NE(run("info").out.find("cpu walk:   " + walk), std::string::npos);
  ::setenv("IRGRID_CPU_WALK", "single", 1);
  const auto forced = run("info --json");
  ::unsetenv("IRGRID_CPU_WALK");
  ASSERT_EQ(forced.code, 0) << forced.err;
  EXPECT_EQ(nlohmann::json::parse(forced.out)["cpu_walk"], "single");
}

TEST_F(Cli, InfoOnASceneReportsItsTriangles) {
  const auto r = run("info builtin:cube --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  EXPECT_EQ(json["scene"]["triangles"], 12);
  EXPECT_EQ(json["scene"]["dropped"]["degenerate"], 0);
}

TEST_F(Cli, MissingSceneFileIsExitTwoNamingThePath) {
  const auto r = run("info /nonexistent/scene.obj");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("/nonexistent/scene.obj"), std::string::npos) << r.err;
}

TEST_F(Cli, MalformedObjIsExitTwoNamingTheLine) {
  std::ofstream(dir / "broken.obj") << "v 0 0 0\nv 1 0 0\nv 0 oops 0\nf 1 2 3\n";
  const auto r = run("info " + (dir / "broken.obj").string());
  EXPECT_EQ(r.code, 2);
  // The scratch path holds the process id, so "3" alone could match it: look for the line.
  EXPECT_NE(r.err.find("broken.obj: line 3:"), std::string::npos) << r.err;
}

TEST_F(Cli, BadOptionValuesAreExitTwo) {
  EXPECT_EQ(run("rays builtin:cube --kind shadow -o " + (dir / "x.rays").string()).code, 2);
  EXPECT_EQ(run("bench builtin:cube --structure kd-tree").code, 2);
  EXPECT_EQ(run("render builtin:cube --mode xray -o " + (dir / "x.png").string()).code, 2);
  EXPECT_EQ(run("render builtin:cube --fov 180 -o " + (dir / "x.png").string()).code, 2);
  EXPECT_EQ(run("bench builtin:cube --compare ,").code, 2);
  EXPECT_EQ(run("--threads -3 info").code, 2);
  EXPECT_EQ(run("frobnicate").code, 2);
  EXPECT_EQ(run("info builtin:nosuchscene").code, 2);
  EXPECT_EQ(run("--help").code, 0);
}

TEST_F(Cli, BadGridOptionsAreExitTwoBeforeLoading) {
  // The library would reject most of these only after loading the scene; --expansion-passes -1
  // and --alpha nan it would even take, as "off".
  for (const char* option :
       {"--lambda1 0", "--lambda1 -1", "--lambda2 nan", "--alpha nan", "--alpha inf",
        "--cost-ratio -2", "--empty-aspect 0.5", "--expansion-passes -1"}) {
    const Result r = run(std::string("build builtin:cube ") + option);
    EXPECT_EQ(r.code, 2) << option;
    const std::string name(option, std::string(option).find(' '));
    EXPECT_NE(r.err.find(name + ": "), std::string::npos) << option << ": " << r.err;
    EXPECT_EQ(r.err.find("loaded"), std::string::npos) << option << ": the scene was loaded first";
  }
  EXPECT_EQ(run("build builtin:cube --alpha -1 --expansion-passes 0 --empty-aspect 0").code, 0);
}

TEST_F(Cli, UnwritableJsonIsExitTwoBeforeLoading) {
  const std::string json = (dir / "no-such-folder" / "out.json").string();
  for (const char* command : {"build builtin:cube", "bench builtin:cube --repeat 1"}) {
    const Result r = run(std::string(command) + " --json " + json);
    EXPECT_EQ(r.code, 2) << command;
    EXPECT_NE(r.err.find(json + ": cannot create"), std::string::npos) << command << ": " << r.err;
    EXPECT_EQ(r.err.find("loaded"), std::string::npos) << command << ": the scene was loaded first";
  }
}

TEST_F(Cli, UnwritableOutputsAndEmptyImagesAreExitTwoBeforeLoading) {
  const std::string missing = (dir / "no-such-folder" / "out").string();
  const auto rays = (dir / "cube.rays").string();
  ASSERT_EQ(run("rays builtin:cube -o " + rays + " -w 8 -h 8").code, 0);
  for (const std::string command :
       {"render builtin:cube -o " + missing, "rays builtin:cube -o " + missing,
        "trace builtin:cube --rays " + rays + " -o " + missing}) {
    const Result r = run(command);
    EXPECT_EQ(r.code, 2) << command;
    EXPECT_NE(r.err.find(missing + ": cannot create"), std::string::npos) << command << r.err;
    EXPECT_EQ(r.err.find("loaded"), std::string::npos) << command << ": the scene was loaded first";
  }
  for (const char* command :
       {"bench builtin:cube --width 0", "bench builtin:cube --height -3",
        "rays builtin:cube -o x.rays -w 0", "render builtin:cube -o x.png -h 0"}) {
    const Result r = run(command);
    EXPECT_EQ(r.code, 2) << command;
    EXPECT_EQ(r.err.find("loaded"), std::string::npos) << command << ": the scene was loaded first";
  }
}

TEST_F(Cli, BadBenchRaysFailBeforeAnyBuild) {
  const auto views = (dir / "broken-views.json").string();
  std::ofstream(views) << "{\"x\": [";
  const std::vector<std::string> commands = {
      "bench builtin:cube --kinds primary,foo", "bench builtin:cube --views 3",
      "bench builtin:cube --views-file " + views, "bench builtin:cube --spp 0",
      "bench builtin:cube --rays " + views};
  for (const auto& command : commands) {
    const Result r = run(command);
    EXPECT_EQ(r.code, 2) << command;
    EXPECT_EQ(r.err.find("built irregular"), std::string::npos) << command << ": built first";
  }
}

TEST_F(Cli, AFailedCommandLeavesNoEmptyOutputBehind) {
  const auto json = dir / "never.json";
  fs::remove(json);
  EXPECT_EQ(run("build " + (dir / "missing.obj").string() + " --json " + json.string()).code, 2);
  EXPECT_FALSE(fs::exists(json));
}

TEST_F(Cli, BuildPrintsPhasesInTheOrderTheyRun) {
  const Result r = run("build builtin:cornell");
  ASSERT_EQ(r.code, 0) << r.err;
  const char* phases[] = {"top grid",      "top-level references",
                          "octree levels", "cells and references",
                          "merge",         "voxel map",
                          "expansion"};
  std::size_t last = 0;
  for (const char* phase : phases) {
    const std::size_t at = r.out.find(std::string("phase ") + phase);
    ASSERT_NE(at, std::string::npos) << phase << "\n" << r.out;
    EXPECT_GT(at, last) << phase << " out of order:\n" << r.out;
    last = at;
  }
  EXPECT_NE(r.out.find("peak memory during the build"), std::string::npos) << r.out;
}

TEST_F(Cli, UnknownOrUnavailableBackendIsExitTwoBeforeLoading) {
  const Result unknown = run("build builtin:cube --backend gpu");
  EXPECT_EQ(unknown.code, 2);
  EXPECT_NE(unknown.err.find("unknown backend 'gpu'"), std::string::npos) << unknown.err;
  const Result cuda = run("build builtin:cube --backend cuda");
  if (cuda.code == 0) GTEST_SKIP() << "a GPU is visible";
  EXPECT_EQ(cuda.code, 2);
  EXPECT_NE(cuda.err.find("no device"), std::string::npos) << cuda.err;
  EXPECT_EQ(cuda.err.find("loaded"), std::string::npos) << "the scene was loaded first";
  EXPECT_EQ(run("build builtin:cube --backend auto").code, 0);
}

TEST_F(Cli, RaysThenTraceWritesOneHitPerRay) {
  const auto rays = (dir / "cornell.rays").string(), hits = (dir / "cornell.hits").string();
  auto r = run("rays builtin:cornell --kind primary -w 20 -h 10 -o " + rays);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(fs::file_size(rays), 200u * 32u);
  r = run("trace builtin:cornell --rays " + rays + " -o " + hits + " --structure brute");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(fs::file_size(hits), 200u * 16u);
  r = run("trace builtin:cornell --rays " + rays + " --any-hit -o " + hits);
  ASSERT_EQ(r.code, 0) << r.err;
  std::vector<float> records(200 * 4);
  std::ifstream(hits, std::ios::binary).read(reinterpret_cast<char*>(records.data()), 200 * 16);
  for (int i = 0; i < 200; ++i)
    EXPECT_EQ(records[i * 4 + 1], 0.f) << "closed room: all occluded";
}

TEST_F(Cli, TraceReadsHagridRaysWithGivenInterval) {
  const auto rays = (dir / "h.rays").string(), hits = (dir / "h.hits").string();
  ASSERT_EQ(run("rays builtin:cube --kind random --count 50 --format hagrid -o " + rays).code, 0);
  EXPECT_EQ(fs::file_size(rays), 50u * 24u);
  const auto r = run("trace builtin:cube --rays " + rays + " --format hagrid --tmax 0 -o " + hits);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("(0 hits)"), std::string::npos) << "tmax 0 leaves nothing to hit: " << r.out;
  // An interval that is empty for every ray is a mistake on the command line.
  const auto empty =
      run("trace builtin:cube --rays " + rays + " --format hagrid --tmin 5 --tmax 1 -o " + hits);
  EXPECT_EQ(empty.code, 2);
  EXPECT_NE(empty.err.find("--tmin 5 and --tmax 1"), std::string::npos) << empty.err;
}

TEST_F(Cli, BenchValidatesAndWritesJson) {
  const auto [r, json] = run_json(
      "bench builtin:cornell --structure brute --width 24 --height 16 --repeat 2 --validate 200",
      "bench.json");
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* key : {"scene", "scene_file", "triangles", "backend", "structure", "build_ms",
                          "build_phases_ms", "memory_bytes", "machine", "runs"})
    EXPECT_TRUE(json.contains(key)) << key;
  EXPECT_EQ(json["scene_file"], "builtin:cornell");
  ASSERT_EQ(json["runs"].size(), 8u);  // 2 views x 4 kinds
  for (const auto& run : json["runs"]) {
    EXPECT_EQ(run["mismatches"], 0);
    EXPECT_EQ(run["checked"], std::min<int>(200, run["rays"].get<int>()));
  }
}

TEST_F(Cli, BenchHitArraysTimesTheTraceIntoSeparateArraysOfEveryStructure) {
  // The grid walks the arrays itself; Embree converts around its trace: both are checked
  // against their Hit records, normals included, before a figure is written.
  const auto [r, json] = run_json(
      "bench builtin:cornell --compare irregular,embree --kinds primary,random --width 24 "
      "--height 16 --repeat 1 --hit-arrays",
      "arrays.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("--hit-arrays"), std::string::npos) << r.out;
  EXPECT_EQ(json["settings"]["hit_arrays"], true);
  ASSERT_EQ(json["compare"].size(), 2u);
  for (const auto& result : json["compare"]) {
    ASSERT_EQ(result["runs"].size(), 4u) << result["structure"];  // 2 views x 2 kinds
    for (const auto& run : result["runs"]) {
      EXPECT_GT(run["arrays_mrays_per_s"].get<double>(), 0) << run;
      EXPECT_GT(run["arrays_median_ms"].get<double>(), 0) << run;
    }
  }
}

TEST_F(Cli, BenchRebuildTimesEveryFrameOfEveryStructureAndValidatesTheLast) {
  const auto [r, json] = run_json(
      "bench builtin:sphere:2000 --rebuild 3 --compare irregular,uniform --width 32 --height 24 "
      "--validate 300",
      "rebuild.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("median"), std::string::npos) << r.out;
  ASSERT_TRUE(json.contains("rebuild")) << json.dump();
  EXPECT_EQ(json["rebuild"]["frames"], 3);
  ASSERT_EQ(json["rebuild"]["structures"].size(), 2u);
  for (const auto& s : json["rebuild"]["structures"]) {
    EXPECT_EQ(s["frame_ms"].size(), 3u) << s.dump();
    EXPECT_GT(s["median_ms"].get<double>(), 0.0);
    EXPECT_EQ(s["checked"], 300);
    EXPECT_EQ(s["mismatches"], 0);
  }
  EXPECT_EQ(json["rebuild"]["structures"][0]["structure"], "irregular");
  EXPECT_EQ(json["rebuild"]["structures"][1]["structure"], "uniform");
}

TEST_F(Cli, BenchPaperTableComparesTheGridWithTheCwbvhOnThePapersRayKinds) {
  const auto structures = irgrid::available_structures();
  if (std::find(structures.begin(), structures.end(), irgrid::Structure::cwbvh) == structures.end())
    GTEST_SKIP() << "no cwbvh (Embree) in this build";
  const auto [r, json] = run_json(
      "bench builtin:cornell --paper-table --views 0 --width 24 --height 16 --repeat 1 "
      "--validate 300",
      "paper.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("| scene | view | triangles | structure | build ms | memory MiB | primary "
                       "| ao | random |"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("| irregular@cpu / cwbvh@cpu |"), std::string::npos) << r.out;
  ASSERT_EQ(json["compare"].size(), 2u);
  EXPECT_EQ(json["compare"][1]["structure"], "cwbvh");
  ASSERT_EQ(json["compare"][1]["runs"].size(), 3u);  // primary, ao, random
  for (const auto& run : json["compare"][1]["runs"])
    EXPECT_EQ(run["mismatches"], 0);
  EXPECT_TRUE(json["compare"][1]["build_phases_ms"].contains("bvh build"));
  EXPECT_FALSE(json["compare"][1].contains("config"));  // grid parameters: grids only
  EXPECT_EQ(run("bench builtin:cornell --paper-table --rays nowhere.rays").code, 2);
}

TEST_F(Cli, BenchBuildRepeatCountsTheTimedBuilds) {
  const auto [r, json] = run_json(
      "bench builtin:cornell --kinds primary --views 0 --width 8 --height 8 --repeat 2 "
      "--build-repeat 0 --validate 20",
      "build-repeat.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("(median of 1 builds)"), std::string::npos) << r.err;
  EXPECT_GT(json["build_ms"].get<double>(), 0.0);
  EXPECT_EQ(run("bench builtin:cornell --build-repeat -1").code, 2);
}

TEST_F(Cli, ThreadsOptionCapsTheThreadPool) {
  const auto [r, json] = run_json(
      "--threads 1 bench builtin:cornell --kinds primary --views 0 --width 16 --height 16 "
      "--repeat 1 --validate 50",
      "one-thread.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find(", 1 threads"), std::string::npos) << r.out;
  EXPECT_EQ(json["machine"]["threads"], 1);
  EXPECT_EQ(run("--threads -2 info").code, 2);
}

TEST_F(Cli, BuildPrintsStatisticsAndJson) {
  const auto [r, json] = run_json("build builtin:cornell --lambda1 0.5 --lambda2 3", "build.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("cells"), std::string::npos);
  EXPECT_EQ(json["structure"], "irregular");
  EXPECT_EQ(json["scene_file"], "builtin:cornell");
  EXPECT_GT(json["counts"]["cells"].get<int>(), 0);
  EXPECT_FLOAT_EQ(json["config"]["lambda1"].get<float>(), 0.5f);
  EXPECT_GT(json["memory_breakdown_bytes"]["voxel_map"].get<int>(), 0);
  EXPECT_TRUE(json["config"]["skip_empty"].get<bool>());
  EXPECT_GT(json["memory_breakdown_bytes"]["empty_radii"].get<int>(), 0);
  EXPECT_GT(json["build_phases_ms"].count("empty space"), 0u);
  // The build's memory peak per phase, one for every phase that ran.
  EXPECT_EQ(json["build_phase_peak_bytes"].size(), json["build_phases_ms"].size());
  EXPECT_GT(json["build_phase_peak_bytes"]["merge"].get<std::uint64_t>(), 0u);
  const auto [walled, walled_json] =
      run_json("build builtin:cornell --no-skip-empty", "walled.json");
  ASSERT_EQ(walled.code, 0) << walled.err;
  EXPECT_FALSE(walled_json["config"]["skip_empty"].get<bool>());
  EXPECT_EQ(walled_json["memory_breakdown_bytes"].count("empty_radii"), 0u);
  EXPECT_EQ(run("build builtin:cornell --lambda1 -1").code, 2);
}

TEST_F(Cli, BuildFingerprintIsEqualForEqualGridsOnly) {
  const auto fingerprint = [&](const std::string& command, const std::string& file) {
    const auto [r, json] = run_json(command + " --fingerprint", file);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("grid fingerprint"), std::string::npos) << r.out;
    return r.code == 0 ? json["grid_fingerprint"].get<std::string>() : std::string();
  };
  const std::string first = fingerprint("--threads 1 build builtin:hairball:3000", "fp1.json");
  EXPECT_EQ(first.size(), 16u);
  // Deterministic whatever the thread count; another grid, another hash.
  EXPECT_EQ(fingerprint("build builtin:hairball:3000", "fp2.json"), first);
  EXPECT_NE(fingerprint("build builtin:hairball:3000 --expansion-passes 0", "fp3.json"), first);
  const Result embree = run("build builtin:cornell --structure embree --fingerprint");
  if (embree.err.find("not available") == std::string::npos) {
    EXPECT_EQ(embree.code, 2);
    EXPECT_NE(embree.err.find("--fingerprint"), std::string::npos) << embree.err;
  }
}

TEST_F(Cli, BuildReportsTheProcessMemoryOfEachPhase) {
  const auto [r, json] = run_json("build builtin:hairball:3000", "memory.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("process memory at each phase's end"), std::string::npos) << r.out;
  const auto& phases = json["phase_process_memory"];
  // One entry per phase that ran, each as large as the phase times say ran.
  EXPECT_EQ(phases.size(), json["build_phases_ms"].size()) << phases.dump();
#if defined(__linux__)
  // The whole command's peak covers every phase's (the kernel's restarts with each phase).
  const double whole = json["process_peak_bytes"].get<double>();
  EXPECT_NE(r.out.find("process memory peak"), std::string::npos) << r.out;
  for (const auto& [phase, memory] : phases.items()) {
    EXPECT_GT(memory["resident_bytes"].get<double>(), 0) << phase;
    EXPECT_GE(memory["peak_bytes"].get<double>(), memory["resident_bytes"].get<double>()) << phase;
    EXPECT_GE(whole, memory["peak_bytes"].get<double>()) << phase;
  }
#endif
}

TEST_F(Cli, BuildSaysWhenASmallSceneRaisesLambda2) {
  const auto [raised, raised_json] = run_json("build builtin:cornell", "raised.json");
  ASSERT_EQ(raised.code, 0) << raised.err;
  const auto refs = raised_json["counts"]["top_level_references"].get<double>();
  const auto min_cells = raised_json["config"]["min_cells"].get<double>();
  ASSERT_GT(refs, 0);
  EXPECT_NEAR(raised_json["lambda2_used"].get<double>(), min_cells / refs, 1e-9);
  EXPECT_NE(raised.out.find("lambda2 used"), std::string::npos) << raised.out;
  const auto [paper, paper_json] = run_json("build builtin:cornell --min-cells 0", "paper.json");
  ASSERT_EQ(paper.code, 0) << paper.err;
  EXPECT_FLOAT_EQ(paper_json["lambda2_used"].get<float>(), 2.4f);
  EXPECT_EQ(paper.out.find("lambda2 used"), std::string::npos) << paper.out;
  EXPECT_EQ(run("build builtin:cornell --min-cells -1").code, 2);
}

TEST_F(Cli, PrimitiveProfileListsTheBuildsPrimitives) {
  ::setenv("IRGRID_PRIMITIVE_PROFILE", "1", 1);
  const Result r = run("build builtin:cornell");
  ::unsetenv("IRGRID_PRIMITIVE_PROFILE");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("primitive octree top cells"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("primitive expand cells"), std::string::npos) << r.err;
  EXPECT_EQ(run("build builtin:cornell").err.find("primitive "), std::string::npos);
}

TEST_F(Cli, CompareRunsEveryStructureOnTheSameRays) {
  const auto [r, json] = run_json(
      "bench builtin:cornell --compare all --kinds primary,ao --views 0 --width 16 --height 16 "
      "--repeat 1 --validate 100",
      "compare.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("comparison"), std::string::npos);
  ASSERT_GE(json["compare"].size(), 3u);  // irregular, two-level, uniform (+ the two Embrees)
  for (const auto& result : json["compare"]) {
    ASSERT_EQ(result["runs"].size(), 2u);
    EXPECT_EQ(result["runs"][0]["rays"], json["compare"][0]["runs"][0]["rays"]);
    EXPECT_EQ(result["runs"][1]["rays"], json["compare"][0]["runs"][1]["rays"]);
    for (const auto& run : result["runs"])
      EXPECT_EQ(run["mismatches"], 0) << result["structure"] << " " << run["kind"];
    // Grids and the cwbvh report their work per ray; brute force and Embree do not count.
    const auto structure = result["structure"].get<std::string>();
    const bool counts = structure.rfind("embree", 0) != 0 && structure != "brute";
    const bool grid = counts && structure != "cwbvh";
    EXPECT_EQ(result["runs"][0].contains("cells_per_ray"), counts) << result["structure"];
    if (counts) {
      EXPECT_GE(result["runs"][0]["cells_per_ray"].get<double>(), 1.0);
      EXPECT_GT(result["runs"][0]["tests_per_ray"].get<double>(), 0.0);
    }
    // The grid parameters go with the grids only; the λ2 used with the irregular grid only.
    EXPECT_EQ(result.contains("config"), grid) << result["structure"];
    EXPECT_EQ(result.contains("lambda2_used"), structure == "irregular") << structure;
  }
  // Cornell is small enough for min_cells to raise the irregular grid's λ2.
  EXPECT_GT(json["lambda2_used"].get<double>(), json["config"]["lambda2"].get<double>());
}

TEST_F(Cli, BenchJsonSaysHowTheRaysWereMade) {
  const auto [r, json] = run_json(
      "bench builtin:cornell --kinds primary,random --views 1 --width 12 --height 10 --count 77 "
      "--seed 5 --spp 2 --repeat 2 --build-repeat 1 --validate 30 --lambda1 0.5",
      "settings.json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto& settings = json["settings"];
  EXPECT_EQ(settings["width"], 12);
  EXPECT_EQ(settings["height"], 10);
  EXPECT_EQ(settings["random_rays"], 77);
  EXPECT_EQ(settings["seed"], 5);
  EXPECT_EQ(settings["spp"], 2);
  EXPECT_EQ(settings["kinds"], "primary,random");
  EXPECT_EQ(settings["views"], "1");
  EXPECT_EQ(settings["repeat"], 2);
  EXPECT_EQ(settings["build_repeat"], 1);
  EXPECT_EQ(settings["validate"], 30);
  EXPECT_FLOAT_EQ(json["config"]["lambda1"].get<float>(), 0.5f);
  EXPECT_FALSE(json["machine"]["cpu_walk"].get<std::string>().empty());
  ASSERT_EQ(json["runs"].size(), 2u);
  EXPECT_EQ(json["runs"][1]["rays"], 77);
  EXPECT_EQ(settings["validate_reference"], "double");
}

TEST_F(Cli, BenchExactValidatesAgainstTheOracleAndCountsEachFault) {
  const auto [r, json] = run_json(
      "bench builtin:cornell --kinds primary,ao --width 24 --height 16 --spp 2 --repeat 1 "
      "--validate 200 --exact",
      "exact.json");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(json["settings"]["validate_reference"], "exact");
  EXPECT_NE(r.out.find("wrong-uv"), std::string::npos) << r.out;
  ASSERT_FALSE(json["runs"].empty());
  for (const auto& run : json["runs"]) {
    EXPECT_EQ(run["checked"], 200) << run["kind"];
    EXPECT_EQ(run["mismatches"], 0) << run["kind"];
    for (const char* key : {"wrong_triangle", "wrong_t", "wrong_uv", "outside_window", "fragile",
                            "unbounded", "unlocated"})
      EXPECT_TRUE(run["validation"].contains(key)) << key;
    EXPECT_EQ(run["validation"]["unlocated"], 0) << "the irregular grid says where it is occluded";
  }
}

/// The mean, 99th percentile and largest work per ray that `render --mode heatmap` printed.
std::array<double, 3> heatmap_work(const std::string& out) {
  std::array<double, 3> work{-1, -1, -1};
  std::sscanf(out.c_str(),
              "work per ray (cells + triangle tests): mean %lf, 99th percentile %lf, max %lf",
              &work[0], &work[1], &work[2]);
  return work;
}

TEST_F(Cli, HeatmapRendersWorkPerPixel) {
  const auto png = (dir / "heat.png").string();
  const auto r = run("render builtin:cornell --mode heatmap -w 32 -h 24 -o " + png);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto work = heatmap_work(r.out);
  EXPECT_GE(work[0], 1.0) << "every ray visits a cell: " << r.out;
  EXPECT_LE(work[0], work[2]) << r.out;
  EXPECT_LE(work[1], work[2]) << r.out;
  std::ifstream file(png, std::ios::binary);
  char magic[4] = {};
  file.read(magic, 4);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  // The picture measures the structure: the uniform grid does far more work per ray on the
  // teapot in the stadium than the irregular grid.
  const auto scene =
      std::string("render builtin:teapot-stadium --mode heatmap -w 32 -h 24 -o ") + png;
  const auto irregular_run = run(scene), uniform_run = run(scene + " --structure uniform");
  ASSERT_EQ(irregular_run.code, 0) << irregular_run.err;
  ASSERT_EQ(uniform_run.code, 0) << uniform_run.err;
  const auto irregular = heatmap_work(irregular_run.out), uniform = heatmap_work(uniform_run.out);
  ASSERT_GE(irregular[0], 1.0) << "a parsed work count: " << irregular_run.out;
  EXPECT_GT(uniform[0], 10 * irregular[0]);
  EXPECT_EQ(run("render builtin:cornell --mode heatmap --structure brute -w 8 -h 8 -o " + png).code,
            2);
}

TEST_F(Cli, RenderWritesAPng) {
  const auto png = (dir / "cornell.png").string();
  const auto r = run("render builtin:cornell -w 64 -h 48 -o " + png);
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream file(png, std::ios::binary);
  char magic[4] = {};
  file.read(magic, 4);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
}

}  // namespace

namespace irgrid {
namespace {

TEST_F(Cli, AFullDiskFailsTheCommandAndLeavesNoTruncatedFile) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  // render and build --json once said "wrote ..." and exited 0.
  for (const std::string& command :
       {"render builtin:cube -w 16 -h 16 -o /dev/full", "rays builtin:cube -w 8 -h 8 -o /dev/full",
        "build builtin:cube --json /dev/full",
        "bench builtin:cube --width 8 --height 8 --repeat 1 --json /dev/full"}) {
    const auto r = run(command);
    EXPECT_NE(r.code, 0) << command;
    EXPECT_NE(r.err.find("/dev/full"), std::string::npos) << command << ": " << r.err;
  }
  // A complete file appears only under its final name, with no temporary file left beside it.
  const auto png = dir / "whole.png";
  fs::remove(png);
  ASSERT_EQ(run("render builtin:cube -w 16 -h 16 -o " + png.string()).code, 0);
  EXPECT_GT(fs::file_size(png), 8u);
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"), std::string::npos) << entry.path();
}

TEST_F(Cli, ABudgetLimitedBuildWarnsAndSucceeds) {
  const auto r = run("build builtin:teapot-stadium:3000 --memory-budget 1");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: the grid reached its construction budget of 1 MiB"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(run("build builtin:teapot-stadium:3000").err.find("construction budget"),
            std::string::npos);
}

TEST_F(Cli, EmbreeTracesRaysWithANegativeTmin) {
  const auto structures = available_structures();
  if (std::find(structures.begin(), structures.end(), Structure::embree) == structures.end())
    GTEST_SKIP() << "no Embree in this build";
  const auto rays = (dir / "negative.rays").string(), hits = (dir / "negative.hits").string();
  ASSERT_EQ(run("rays builtin:cube --kind random --count 50 --format hagrid -o " + rays).code, 0);
  for (const char* structure : {"embree", "embree-packets"}) {
    const auto r = run("trace builtin:cube --rays " + rays + " --format hagrid --tmin -1 -o " +
                       hits + " --structure " + structure);
    EXPECT_EQ(r.code, 0) << structure << ": " << r.err;
  }
}

}  // namespace
}  // namespace irgrid
