// irgrid: the command-line tool. Errors go to stderr with exit code 2.
#include <cstdio>
#include <new>
#include <optional>

#include <tbb/global_control.h>

#include <fmt/format.h>

#include "commands.h"
#include "irgrid/error.h"
#include "irgrid/system.h"

int main(int argc, char** argv) {
  CLI::App app{
      "irgrid: irregular grids (Perard-Gayot et al., EG 2017) for fast ray tracing.\n"
      "Scenes: .obj or .ply files (optionally .gz/.xz) or builtin:NAME[:N]."};
  app.set_version_flag("--version", irgrid::version());
  app.require_subcommand(1, 1);
  // Lives until the command has run: every TBB pool (ours, Embree's) is capped while it exists.
  std::optional<tbb::global_control> thread_cap;
  app.add_option_function<int>(
         "--threads",
         [&](int threads) {
           if (threads > 0)
             thread_cap.emplace(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
         },
         "CPU threads for builds and traces (default: all hardware threads)")
      ->check(CLI::Range(0, 1 << 16).description("0 (all) to 65536"));
  irgrid::cli::add_info_command(app);
  irgrid::cli::add_build_command(app);
  irgrid::cli::add_rays_command(app);
  irgrid::cli::add_trace_command(app);
  irgrid::cli::add_render_command(app);
  irgrid::cli::add_bench_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::RuntimeError& e) {  // a command's own non-zero exit (bench mismatches)
    return e.get_exit_code();
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  } catch (const irgrid::Error& e) {
    fmt::print(stderr, "irgrid: error ({}): {}\n", irgrid::to_string(e.code()), e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    fmt::print(stderr, "irgrid: error (out of memory): host memory exhausted\n");
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "irgrid: error (internal): {}\n", e.what());
    return 2;
  }
  return 0;
}
