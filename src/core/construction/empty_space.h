// core/construction/empty_space.h: how far empty space reaches ahead of each top cell, so that a
// ray in empty space can leap across it (irgrid/kernel/grid_traverse.h, leave_empty_space).
//
// Most cells a ray visits in a scene with much empty space are empty: 90% of the cells that
// Crown's primary rays visited, 83% of those in empty top cells, although merging and expansion
// had already made them large. The chessboard (L∞) distance from an empty top cell to the
// nearest top cell that triangles overlap gives a cube of empty top cells; a ray in it may step
// to the cube's exit at once ("proximity clouds", Cohen and Sheffer 1994, here on the top grid
// only). A ray only moves forward, so the cube need only extend the way it goes: one radius per
// octant of directions, the one-sided distance to the nearest top cell with triangles in that
// octant, reaches much farther near geometry than a cube centred on the cell (Crown's primary
// rays: 8.3 cells with octant cubes, 10.5 with centred ones, 13.5 without leaps). The distance
// transform is separable: with f = 0 on occupied cells and "far" elsewhere, min over k >= 0 of
// max(k, f(x + k s)) along x, then along y, then along z is the one-sided L∞ distance, because
// max distributes over min.
#pragma once

#include <cstdint>

#include "irgrid/kernel/grid_layout.h"
#include "irgrid/kernel/platform.h"

namespace irgrid {

/// The largest radius stored: distances of more top cells are kept at this.
inline constexpr std::uint32_t kMaxEmptyRadius = 255;

/// Grids with more top cells than this get no radii (their walks do not leap): 8 radii per top
/// cell must stay addressable with 32-bit indices, lane-wise gathers included.
inline constexpr std::uint64_t kMaxEmptyRadiiTopCells = std::uint64_t(1) << 27;

/// One axis of the transform, one-sided: out[c] = min over the cells c + k x step (k >= 0) of
/// the line of max(k, in[c + k x step]), for the line of cells that starts at `first` with
/// `count` cells `stride` apart; `forward` picks the sign of step.
IRGRID_HD inline void chessboard_line(const std::uint8_t* in, std::uint8_t* out,
                                      std::uint32_t first, std::uint32_t count,
                                      std::uint32_t stride, bool forward) {
  for (std::uint32_t i = 0; i < count; ++i) {
    std::uint32_t best = in[first + i * stride];
    // Cells k steps away contribute at least k: stop once k reaches the best so far.
    const std::uint32_t room = forward ? count - 1 - i : i;
    for (std::uint32_t k = 1; k < best && k <= room; ++k) {
      const std::uint32_t there = in[first + (forward ? i + k : i - k) * stride];
      if (there < best) best = there > k ? there : k;
    }
    out[first + i * stride] = std::uint8_t(best);
  }
}

/// The empty radii of every top cell, 8 per cell (one per octant, walk_octant), top cells
/// indexed like the top level of the voxel map: r for top cell c and an octant of directions
/// s means that the cells c + k ⊙ s, for every k in [0, r)^3, hold no triangles
/// (refs_per_top_cell is 0), capped at kMaxEmptyRadius; 0 where c has triangles. A walk
/// heading into that octant may leap to where it leaves the cube (traverse.h). The buffer holds
/// kEmptyRadiiSlack bytes more; it is empty (no leaps) above kMaxEmptyRadiiTopCells top cells.
template <typename Exec>
typename Exec::template Buffer<std::uint8_t> empty_space_radii(
    Exec& exec, const GridInfo& info, const std::uint32_t* refs_per_top_cell) {
  const std::uint32_t nx = std::uint32_t(info.top_dims[0]), ny = std::uint32_t(info.top_dims[1]),
                      nz = std::uint32_t(info.top_dims[2]);
  if (std::uint64_t(nx) * ny * nz > kMaxEmptyRadiiTopCells) return {};
  const std::uint32_t n = nx * ny * nz;
  auto radii = exec.template allocate<std::uint8_t>(8 * std::size_t(n) + kEmptyRadiiSlack);
  auto seeds = exec.template allocate<std::uint8_t>(n);
  auto scratch = exec.template allocate<std::uint8_t>(n);
  auto along = exec.template allocate<std::uint8_t>(n);
  std::uint8_t* d_radii = radii.data();
  std::uint8_t* d_seeds = seeds.data();
  std::uint8_t* d_scratch = scratch.data();
  std::uint8_t* d_along = along.data();
  exec.for_each("empty seeds", n, [=] IRGRID_HD(std::size_t i) {
    d_seeds[i] = refs_per_top_cell[i] == 0 ? std::uint8_t(kMaxEmptyRadius) : 0;
  });
  exec.for_each("empty slack", kEmptyRadiiSlack,
                [=] IRGRID_HD(std::size_t i) { d_radii[8 * std::size_t(n) + i] = 0; });
  for (std::uint32_t octant = 0; octant < 8; ++octant) {
    const bool up_x = !(octant & 1), up_y = !(octant & 2), up_z = !(octant & 4);
    // x lines into scratch, y lines into `along`, z lines into scratch, then interleaved.
    exec.for_each("empty along x", ny * nz, [=] IRGRID_HD(std::size_t line) {
      chessboard_line(d_seeds, d_scratch, std::uint32_t(line) * nx, nx, 1, up_x);
    });
    exec.for_each("empty along y", nx * nz, [=] IRGRID_HD(std::size_t line) {
      const std::uint32_t x = std::uint32_t(line) % nx, z = std::uint32_t(line) / nx;
      chessboard_line(d_scratch, d_along, z * nx * ny + x, ny, nx, up_y);
    });
    exec.for_each("empty along z", nx * ny, [=] IRGRID_HD(std::size_t line) {
      chessboard_line(d_along, d_scratch, std::uint32_t(line), nz, nx * ny, up_z);
    });
    exec.for_each("empty radii", n,
                  [=] IRGRID_HD(std::size_t i) { d_radii[8 * i + octant] = d_scratch[i]; });
  }
  return radii;
}

}  // namespace irgrid
