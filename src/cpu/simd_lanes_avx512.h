// cpu/simd_lanes_avx512.h: the lane operations of the SIMD walk (cpu/simd_walk_lanes.h) on the
// 16 lanes of AVX-512 registers, with lane masks in mask registers. The same operations as
// cpu/simd_lanes_avx2.h, lane for lane.
//
// Include only where AVX-512 code is compiled (cpu/simd_walk_avx512.cpp, after its pragma).
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace irgrid::simd {

/// The operations the SIMD walk needs, for 16 lanes of AVX-512 (AVX-512F only). Minimum and
/// maximum return their second operand when either is not a number, as in AVX2.
struct Avx512Lanes {
  static constexpr int kLanes = 16;
  using F = __m512;     ///< 16 floats
  using I = __m512i;    ///< 16 32-bit integers
  using M = __mmask16;  ///< a lane mask: bit l for lane l

  static F load(const float* p) { return _mm512_load_ps(p); }
  static I load(const std::int32_t* p) { return _mm512_load_si512(p); }
  static void store(float* p, F v) { _mm512_store_ps(p, v); }
  static void store(std::int32_t* p, I v) { _mm512_store_si512(p, v); }
  static void store_unaligned(std::int32_t* p, I v) { _mm512_storeu_si512(p, v); }
  /// p[k] in the lanes of `valid`, 0 elsewhere; nothing is read outside `valid`.
  static I load_lanes(const std::uint32_t* p, M valid) {
    return _mm512_maskz_loadu_epi32(valid, p);
  }

  static F splat(float x) { return _mm512_set1_ps(x); }
  static I splat(std::int32_t x) { return _mm512_set1_epi32(x); }
  static I lane_index() {
    return _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  }

  static F add(F a, F b) { return _mm512_add_ps(a, b); }
  static F sub(F a, F b) { return _mm512_sub_ps(a, b); }
  static F mul(F a, F b) { return _mm512_mul_ps(a, b); }
  static F div(F a, F b) { return _mm512_div_ps(a, b); }
  static F min(F a, F b) { return _mm512_min_ps(a, b); }
  static F max(F a, F b) { return _mm512_max_ps(a, b); }
  static F abs(F a) { return _mm512_abs_ps(a); }
  static I add(I a, I b) { return _mm512_add_epi32(a, b); }
  static I sub(I a, I b) { return _mm512_sub_epi32(a, b); }
  static I mul(I a, I b) { return _mm512_mullo_epi32(a, b); }
  static I bit_and(I a, I b) { return _mm512_and_si512(a, b); }
  /// ~a & b
  static I bit_and_not(I a, I b) { return _mm512_andnot_si512(a, b); }
  static I bit_or(I a, I b) { return _mm512_or_si512(a, b); }
  template <int kBits>
  static I shift_right_logical(I a) {
    return _mm512_srli_epi32(a, kBits);
  }
  template <int kBits>
  static I shift_left(I a) {
    return _mm512_slli_epi32(a, kBits);
  }
  static I shift_right(I a, int bits) { return _mm512_sra_epi32(a, _mm_cvtsi32_si128(bits)); }
  static I shift_right(I a, I bits) { return _mm512_srav_epi32(a, bits); }
  static I shift_left(I a, I bits) { return _mm512_sllv_epi32(a, bits); }
  static F to_float(I a) { return _mm512_cvtepi32_ps(a); }
  static I truncate(F a) { return _mm512_cvttps_epi32(a); }

  template <int kPredicate>
  static M compare(F a, F b) {
    return _mm512_cmp_ps_mask(a, b, kPredicate);
  }
  static M less(F a, F b) { return compare<_CMP_LT_OQ>(a, b); }
  static M less_equal(F a, F b) { return compare<_CMP_LE_OQ>(a, b); }
  static M equal(I a, I b) { return _mm512_cmpeq_epi32_mask(a, b); }
  static M greater(I a, I b) { return _mm512_cmpgt_epi32_mask(a, b); }
  /// The lanes of an as_int value: those that hold -1.
  static M as_mask(I a) { return _mm512_test_epi32_mask(a, a); }

  static M both(M a, M b) { return M(a & b); }
  static M either(M a, M b) { return M(a | b); }
  /// The lanes of b that are not in a.
  static M but_not(M a, M b) { return M(~a & b); }
  static M all_lanes() { return M(0xffff); }
  static M no_lanes() { return M(0); }
  static bool any(M m) { return m != 0; }
  /// Bit l set for lane l of m.
  static std::uint32_t bits(M m) { return m; }
  /// The lanes whose bit is set in `b`.
  static M lanes(std::uint32_t b) { return M(b); }
  /// The lanes of m as integers: -1 in them, 0 elsewhere (and back with nonzero).
  static I as_int(M m) { return _mm512_maskz_mov_epi32(m, _mm512_set1_epi32(-1)); }
  /// a in the lanes of m, 0 elsewhere.
  static I keep(M m, I a) { return _mm512_maskz_mov_epi32(m, a); }

  /// Per lane: a where m is clear, b where it is set.
  static F select(M m, F a, F b) { return _mm512_mask_blend_ps(m, a, b); }
  static I select(M m, I a, I b) { return _mm512_mask_blend_epi32(m, a, b); }

  /// base[index] (scaled by kScale bytes) in the lanes of m, `fallback` elsewhere.
  template <int kScale>
  static I gather(I fallback, const void* base, I index, M m) {
    return _mm512_mask_i32gather_epi32(fallback, m, index, base, kScale);
  }
  static F gather(const float* base, I index, M m) {
    return _mm512_mask_i32gather_ps(_mm512_setzero_ps(), m, index, base, 4);
  }
  /// Per lane of `takers`, the lane of `givers` it pairs with: the k-th lowest taker with the
  /// k-th lowest giver (both hold as many lanes); other lanes hold 0.
  static I pair_lanes(std::uint32_t takers, std::uint32_t givers) {
    return _mm512_maskz_expand_epi32(M(takers),
                                     _mm512_maskz_compress_epi32(M(givers), lane_index()));
  }
  /// v[index[l]] in lane l.
  static F permute(F v, I index) { return _mm512_permutexvar_ps(index, v); }
  static I permute(I v, I index) { return _mm512_permutexvar_epi32(index, v); }
};

}  // namespace irgrid::simd
