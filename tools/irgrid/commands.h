// tools/irgrid/commands.h: each subcommand registers itself on the CLI11 app.
#pragma once

#include <CLI/CLI.hpp>

namespace irgrid::cli {

void add_info_command(CLI::App& app);
void add_build_command(CLI::App& app);
void add_rays_command(CLI::App& app);
void add_trace_command(CLI::App& app);
void add_render_command(CLI::App& app);
void add_bench_command(CLI::App& app);

}  // namespace irgrid::cli
