// tools/irgrid/paper_table.h: `bench --paper-table`, the table of Pérard-Gayot et al. 2017
// (Table 1: build time and MRays/s for primary, ao and random rays) with this run beside the
// paper's figures.
#pragma once

#include <vector>

#include "bench_report.h"

namespace irgrid::cli {

/// The ray kinds of the paper's table, as bench's --kinds spells them.
inline constexpr const char* kPaperTableKinds = "primary,ao,random";
/// The structures the table compares unless --compare names others.
inline constexpr const char* kPaperTableStructures = "irregular,cwbvh";

/// Prints the results of one scene as Markdown rows under the table's header: per view, each
/// structure's triangles, build ms, memory and MRays/s per kind, and the ratio of the first
/// structure to each other; then, for Sponza, Conference and Crown, the paper's 2017 GPU figures
/// (SBVH and irregular grid) beside them.
void print_paper_table(const std::vector<BenchResult>& results);

}  // namespace irgrid::cli
