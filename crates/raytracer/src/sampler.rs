//! The per-sample source of random numbers: Owen-scrambled Sobol points for the first dimensions
//! of a path, a PCG stream after that.
//!
//! Each call to [`Sampler::uniform2`] takes the next pair of dimensions. Within a pixel, sample
//! `i` of pair `d` is the 2D Sobol (0,2)-sequence point of a shuffled index, with nested uniform
//! (Owen) scrambling seeded by `(seed, pixel, d)` (Burley 2020, "Practical Hash-based Owen
//! Scrambling"). The points of one pixel are therefore stratified in every pair of dimensions
//! for any sample count (perfectly for powers of two), which converges faster than independent
//! random numbers; the shuffling decorrelates the pairs. [`Sampler::uniform`] uses one
//! dimension of such a pair. After [`SOBOL_PAIRS`] pairs (deep bounces, where stratification no
//! longer pays) the numbers come from a PCG stream.
//!
//! Everything depends only on `(seed, pixel, sample index)`, so images do not depend on tiling
//! or threads. The part that depends only on `(seed, pixel)` (the scramble seeds of every pair,
//! the PCG key) is hashed once per pixel by a [`PixelSampler`], which makes the pixel's samplers.

use crate::accel::X86_64V3;
use crate::sampling::{Rng, mix64};
use glam::Vec2;

/// Pairs of dimensions drawn from scrambled Sobol points before switching to PCG: the pixel
/// position and the first two bounces of a path (about 3.5 pairs each: light choice and
/// position, BSDF lobe and direction, Russian roulette). Deeper dimensions gain little from
/// stratification and the scrambling costs more than PCG.
pub const SOBOL_PAIRS: u32 = 8;

/// What the samplers of one pixel share: the scramble seeds of every pair of dimensions and
/// the key of the PCG streams, hashed once per pixel instead of once per sample and pair.
#[derive(Clone, Debug)]
pub struct PixelSampler {
    seeds: [[u32; 3]; SOBOL_PAIRS as usize],
    rng_key: u64,
}

impl PixelSampler {
    /// The samplers of pixel `(x, y)` (full-frame coordinates; pixels outside the frame,
    /// sampled for wide filters, are fine).
    pub fn new(seed: u64, x: i64, y: i64) -> PixelSampler {
        let pixel_seed = mix64(seed ^ mix64(((x as u64) << 32) ^ (y as u64 & 0xffff_ffff) ^ 0x5851_f42d));
        let seeds = std::array::from_fn(|d| {
            let h = mix64(pixel_seed ^ (d as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            // Three scramble seeds from one hash (the Laine-Karras permutation mixes them
            // further).
            let (s0, s1) = (h as u32, (h >> 32) as u32);
            [s0, s1, s0.rotate_left(13) ^ s1.wrapping_mul(0x9e37_79b9)]
        });
        PixelSampler { seeds, rng_key: Rng::pixel_key(seed, x as u32, y as u32) }
    }

    /// The sampler of sample `index` of this pixel.
    #[inline]
    pub fn sample(&self, index: u32) -> Sampler {
        Sampler {
            seeds: self.seeds,
            index_reversed: index.reverse_bits(),
            pair: 0,
            spare: None,
            rng: Rng::for_pixel_key_sample(self.rng_key, index),
        }
    }
}

/// Random numbers for one sample of one pixel.
#[derive(Clone, Debug)]
pub struct Sampler {
    /// The pixel's scramble seeds (see [`PixelSampler`]).
    seeds: [[u32; 3]; SOBOL_PAIRS as usize],
    /// The sample index, bit-reversed once here instead of once per pair (the first step of
    /// the index's Owen scrambling).
    index_reversed: u32,
    pair: u32,
    /// The unused half of the last pair, for one-dimensional requests.
    spare: Option<f32>,
    rng: Rng,
}

#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// The direction numbers of the second dimension of the Sobol sequence, bit-reversed
/// (`v_0 = 1`, `v_k = v_{k-1} ^ v_{k-1} << 1`), XORed together per byte of the index: entry
/// `[j][b]` is the sum of the numbers of the set bits of byte value `b` at byte `j`. Four
/// lookups replace a loop over all 32 bits of the (scrambled, so full-width) index, whose
/// branch per bit mispredicts half the time.
const SOBOL_1_REVERSED_BYTES: [[u32; 256]; 4] = {
    let mut table = [[0u32; 256]; 4];
    let mut v = 1u32;
    let mut bit = 0;
    while bit < 32 {
        let (byte, shift) = (bit / 8, bit % 8);
        let mut b = 0;
        while b < 256 {
            if b >> shift & 1 != 0 {
                table[byte][b] ^= v;
            }
            b += 1;
        }
        v ^= v << 1;
        bit += 1;
    }
    table
};

/// The second dimension of the Sobol sequence, bit-reversed.
#[inline]
fn sobol_1_reversed(i: u32) -> u32 {
    let t = &SOBOL_1_REVERSED_BYTES;
    t[0][(i & 0xff) as usize]
        ^ t[1][(i >> 8 & 0xff) as usize]
        ^ t[2][(i >> 16 & 0xff) as usize]
        ^ t[3][(i >> 24) as usize]
}

/// Each byte value with its eight bits reversed.
const REVERSED_BYTES: [u8; 256] = {
    let mut table = [0u8; 256];
    let mut b = 0;
    while b < 256 {
        table[b] = (b as u8).reverse_bits();
        b += 1;
    }
    table
};

/// `x.reverse_bits() >> 8`: the top 24 bits of the reversal are the low three bytes of `x`,
/// each reversed, so three table lookups replace the 17-instruction reversal and the shift
/// (x86-64 has no bit-reversal instruction).
#[inline]
fn reverse_low_24(x: u32) -> u32 {
    let r = &REVERSED_BYTES;
    u32::from(r[(x & 0xff) as usize]) << 16
        | u32::from(r[(x >> 8 & 0xff) as usize]) << 8
        | u32::from(r[(x >> 16 & 0xff) as usize])
}

/// `x.reverse_bits()` as four table lookups: x86-64 has no bit-reversal instruction, and the
/// generic reversal takes about eighteen instructions.
#[inline]
fn reverse_32(x: u32) -> u32 {
    let r = &REVERSED_BYTES;
    u32::from(r[(x & 0xff) as usize]) << 24
        | u32::from(r[(x >> 8 & 0xff) as usize]) << 16
        | u32::from(r[(x >> 16 & 0xff) as usize]) << 8
        | u32::from(r[(x >> 24) as usize])
}

/// The fixed-point number `x.reverse_bits()` in `[0, 1)`, with 24 bits (exact in `f32`).
#[inline]
fn reversed_to_unit(x: u32) -> f32 {
    reverse_low_24(x) as f32 * (1.0 / 16_777_216.0)
}

/// The point of a Sobol pair that [`Sampler::uniform2`] makes from the reversed sample index
/// and the pair's scramble seeds, with SSE lanes: the shuffled index is reversed with byte
/// shuffles, and the two coordinates' Laine-Karras permutations (`pmulld`) and final
/// reversals share the instructions of one register's lanes 0 and 1. The same integer
/// operations, so the same bits, as the scalar code; about 59 instructions a pair instead of 76.
///
/// `v3` is proof that the CPU has AVX2 (and with it SSSE3 and SSE4.1); the caller should be
/// compiled with x86-64-v3's features, or the intrinsics are calls.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn owen_pair_avx2(v3: X86_64V3, index_reversed: u32, [s0, s1, s2]: [u32; 3]) -> Vec2 {
    use std::arch::x86_64::*;
    let _ = v3;
    /// Each byte's bits reversed, then (`order`) the bytes of each 32-bit lane moved: the
    /// nibbles reversed by two table shuffles, the low one moved up.
    #[inline(always)]
    unsafe fn reverse_bytes_and_move(v: __m128i, order: __m128i) -> __m128i {
        // SAFETY (for the caller): SSSE3 and SSE2 only; no memory is touched.
        unsafe {
            let low_up =
                _mm_setr_epi8(0, -128, 64, -64, 32, -96, 96, -32, 16, -112, 80, -48, 48, -80, 112, -16);
            let high_down = _mm_setr_epi8(0, 8, 4, 12, 2, 10, 6, 14, 1, 9, 5, 13, 3, 11, 7, 15);
            let nibble = _mm_set1_epi8(0x0f);
            let low = _mm_and_si128(v, nibble);
            let high = _mm_and_si128(_mm_srli_epi16::<4>(v), nibble);
            let bytes = _mm_or_si128(_mm_shuffle_epi8(low_up, low), _mm_shuffle_epi8(high_down, high));
            _mm_shuffle_epi8(bytes, order)
        }
    }
    // SAFETY: `v3` exists only on a CPU with AVX2, which implies the SSSE3 and SSE4.1 used
    // here; the intrinsics touch no memory.
    unsafe {
        // `reverse_32`: lane byte k from byte 3 - k. `reverse_low_24`: from byte 2 - k, byte 3
        // zero (a shuffle index with its top bit set writes zero).
        let reverse_32 = _mm_setr_epi8(3, 2, 1, 0, 7, 6, 5, 4, 11, 10, 9, 8, 15, 14, 13, 12);
        let reverse_low_24 = _mm_setr_epi8(2, 1, 0, -128, 6, 5, 4, -128, 10, 9, 8, -128, 14, 13, 12, -128);
        let i =
            reverse_bytes_and_move(_mm_cvtsi32_si128(laine_karras(index_reversed, s0) as i32), reverse_32);
        let sobol = sobol_1_reversed(_mm_cvtsi128_si32(i) as u32);
        // Lane 0 the first coordinate's input, lane 1 the second's, each plus its seed.
        let mut v =
            _mm_add_epi32(_mm_insert_epi32::<1>(i, sobol as i32), _mm_set_epi32(0, 0, s2 as i32, s1 as i32));
        // The constants only in the two lanes used: a splat would be loaded by a broadcast of
        // its own before each multiply, these are the multiplies' memory operands.
        for k in [0x6c50_b47cu32, 0xb82f_1e52, 0xc7af_e638, 0x8d22_f6e6] {
            v = _mm_xor_si128(v, _mm_mullo_epi32(v, _mm_setr_epi32(k as i32, k as i32, 0, 0)));
        }
        let scale = 1.0 / 16_777_216.0;
        let unit = _mm_mul_ps(
            _mm_cvtepi32_ps(reverse_bytes_and_move(v, reverse_low_24)),
            _mm_setr_ps(scale, scale, 0.0, 0.0),
        );
        Vec2::new(_mm_cvtss_f32(unit), _mm_cvtss_f32(_mm_movehdup_ps(unit)))
    }
}

impl Sampler {
    /// The sampler of sample `index` of pixel `(x, y)` (full-frame coordinates; pixels outside
    /// the frame, sampled for wide filters, are fine).
    pub fn new(seed: u64, x: i64, y: i64, index: u32) -> Sampler {
        PixelSampler::new(seed, x, y).sample(index)
    }

    /// A sampler that only uses its PCG stream (for work that is not per pixel, e.g. photons).
    pub fn from_rng(rng: Rng) -> Sampler {
        Sampler {
            seeds: [[0; 3]; SOBOL_PAIRS as usize],
            index_reversed: 0,
            pair: SOBOL_PAIRS,
            spare: None,
            rng,
        }
    }

    /// The next two dimensions. Always inlined (so is [`Sampler::uniform`]): the wavefront's
    /// x86-64-v3 batch then compiles it with its own features.
    #[inline(always)]
    pub fn uniform2(&mut self) -> Vec2 {
        if self.pair >= SOBOL_PAIRS {
            return self.rng.uniform2();
        }
        let [s0, s1, s2] = self.seeds[self.pair as usize];
        self.pair += 1;
        // A shuffled index (nested uniform scrambling of the index: reversed, permuted,
        // reversed back), then both coordinates scrambled; dimension 0 of Sobol is the index
        // bit-reversed, so its scramble needs no reversal going in.
        let i = reverse_32(laine_karras(self.index_reversed, s0));
        let x = laine_karras(i, s1);
        let y = laine_karras(sobol_1_reversed(i), s2);
        Vec2::new(reversed_to_unit(x), reversed_to_unit(y))
    }

    /// The next dimension (half of a pair; the other half serves the next call).
    #[inline(always)]
    pub fn uniform(&mut self) -> f32 {
        if let Some(v) = self.spare.take() {
            return v;
        }
        let p = self.uniform2();
        self.spare = Some(p.y);
        p.x
    }

    /// [`Sampler::uniform2`], the same numbers, taken with SIMD where `v3` says the CPU has
    /// x86-64-v3: the two coordinates of a Sobol pair are permuted and bit-reversed in two
    /// lanes of one register ([`owen_pair_avx2`]) instead of one after the other with table
    /// lookups. Always inlined, for the wavefront's x86-64-v3 batch; a caller without those
    /// target features passes `None` (the intrinsics would be calls).
    #[inline(always)]
    pub(crate) fn uniform2_v3(&mut self, v3: Option<X86_64V3>) -> Vec2 {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = v3
            && self.pair < SOBOL_PAIRS
        {
            let seeds = self.seeds[self.pair as usize];
            self.pair += 1;
            return owen_pair_avx2(v3, self.index_reversed, seeds);
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = v3;
        self.uniform2()
    }

    /// [`Sampler::uniform`] by way of [`Sampler::uniform2_v3`].
    #[inline(always)]
    pub(crate) fn uniform_v3(&mut self, v3: Option<X86_64V3>) -> f32 {
        if let Some(v) = self.spare.take() {
            return v;
        }
        let p = self.uniform2_v3(v3);
        self.spare = Some(p.y);
        p.x
    }

    /// The PCG stream behind the sampler (for decisions that need no stratification).
    pub fn rng(&mut self) -> &mut Rng {
        &mut self.rng
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sixteen samples of a pixel fall one in each cell of a 4x4 grid (the (0,2)-sequence
    /// property survives Owen scrambling), in every pair of dimensions.
    #[test]
    fn pairs_are_stratified() {
        for pixel in [(0i64, 0i64), (17, -3)] {
            for pair in 0..4 {
                let mut cells = [0u32; 16];
                for i in 0..16 {
                    let mut s = Sampler::new(7, pixel.0, pixel.1, i);
                    let mut p = Vec2::ZERO;
                    for _ in 0..=pair {
                        p = s.uniform2();
                    }
                    assert!(p.x >= 0.0 && p.x < 1.0 && p.y >= 0.0 && p.y < 1.0);
                    cells[(p.y * 4.0) as usize * 4 + (p.x * 4.0) as usize] += 1;
                }
                assert!(cells.iter().all(|&c| c == 1), "pixel {pixel:?} pair {pair}: {cells:?}");
            }
        }
    }

    /// The points are those of the plain definition: Owen scrambling as reversal, permutation
    /// and reversal, `u32::reverse_bits` and a 24-bit fixed-point conversion.
    #[test]
    fn points_match_the_definition() {
        let owen_scramble = |x: u32, seed: u32| laine_karras(x.reverse_bits(), seed).reverse_bits();
        let to_unit = |x: u32| (x >> 8) as f32 * (1.0 / 16_777_216.0);
        let mut rng = crate::sampling::Rng::new(5, 9);
        for _ in 0..200 {
            let (seed, x, y) = (
                u64::from(rng.next_u32()),
                i64::from(rng.next_u32() as i16),
                i64::from(rng.next_u32() as i16),
            );
            let index = if rng.next_u32().is_multiple_of(2) { rng.next_u32() % 64 } else { rng.next_u32() };
            let mut s = Sampler::new(seed, x, y, index);
            let pixel_seed = mix64(seed ^ mix64(((x as u64) << 32) ^ (y as u64 & 0xffff_ffff) ^ 0x5851_f42d));
            let mut rng_stream = crate::sampling::Rng::for_pixel_sample(seed, x as u32, y as u32, index);
            for d in 0..SOBOL_PAIRS {
                let h = mix64(pixel_seed ^ u64::from(d).wrapping_mul(0x9e37_79b9_7f4a_7c15));
                let (s0, s1) = (h as u32, (h >> 32) as u32);
                let s2 = s0.rotate_left(13) ^ s1.wrapping_mul(0x9e37_79b9);
                let i = owen_scramble(index, s0);
                let expected = Vec2::new(
                    to_unit(laine_karras(i, s1).reverse_bits()),
                    to_unit(laine_karras(sobol_1_reversed(i), s2).reverse_bits()),
                );
                assert_eq!(s.uniform2(), expected, "pair {d} of sample {index}");
            }
            // Then the sample's PCG stream.
            for _ in 0..4 {
                assert_eq!(s.uniform2(), rng_stream.uniform2());
            }
        }
        for v in (0..=u32::from(u16::MAX)).map(|v| v.wrapping_mul(0x9e37_79b9)).chain([0, u32::MAX]) {
            assert_eq!(reverse_low_24(v), v.reverse_bits() >> 8, "{v:#x}");
            assert_eq!(reverse_32(v), v.reverse_bits(), "{v:#x}");
        }
    }

    /// The SIMD pairs of [`Sampler::uniform2_v3`] and [`Sampler::uniform_v3`] are the scalar
    /// ones bit for bit, through all the Sobol pairs and past them into the PCG stream, for
    /// samples of many pixels and indices (large ones too, whose reversed bits fill all 32),
    /// with one- and two-dimensional requests mixed; `None` takes the scalar code.
    #[test]
    fn simd_pairs_match_the_scalar_ones() {
        let v3 = X86_64V3::detect();
        if v3.is_none() {
            eprintln!("the SIMD pairs are not tested: this CPU lacks x86-64-v3");
        }
        let mut compared = 0;
        for (k, (x, y)) in [(0, 0), (3, -7), (1920, 1080), (-1, 5), (77, 123_456)].into_iter().enumerate() {
            let pixel = PixelSampler::new(k as u64 * 0x9e37_79b9 + 1, x, y);
            for index in [0, 1, 2, 3, 15, 16, 255, 1000, 65_537, 0x7fff_ffff, u32::MAX] {
                for lanes in [v3, None] {
                    let (mut scalar, mut simd) = (pixel.sample(index), pixel.sample(index));
                    for draw in 0..2 * SOBOL_PAIRS + 6 {
                        let (a, b) = if (u64::from(draw) + u64::from(index)) % 3 == 0 {
                            (vec![scalar.uniform()], vec![simd.uniform_v3(lanes)])
                        } else {
                            let (a, b) = (scalar.uniform2(), simd.uniform2_v3(lanes));
                            (vec![a.x, a.y], vec![b.x, b.y])
                        };
                        let bits = |v: Vec<f32>| v.into_iter().map(f32::to_bits).collect::<Vec<_>>();
                        assert_eq!(bits(a), bits(b), "pixel ({x}, {y}), sample {index}, draw {draw}");
                        compared += 1;
                    }
                    assert_eq!(format!("{scalar:?}"), format!("{simd:?}"));
                }
            }
        }
        assert_eq!(compared, 5 * 11 * 2 * (2 * SOBOL_PAIRS as usize + 6));
    }

    /// The byte tables give the same points as the definition, one bit at a time.
    #[test]
    fn sobol_tables_match_the_bit_loop() {
        let by_bits = |mut i: u32| {
            let (mut v, mut r) = (1u32, 0u32);
            while i != 0 {
                if i & 1 != 0 {
                    r ^= v;
                }
                i >>= 1;
                v ^= v << 1;
            }
            r
        };
        let mut rng = crate::sampling::Rng::new(11, 3);
        for i in (0..4096).chain((0..4096).map(|_| rng.next_u32())).chain([u32::MAX, 1 << 31]) {
            assert_eq!(sobol_1_reversed(i), by_bits(i), "index {i:#x}");
        }
    }

    #[test]
    fn pixels_and_pairs_differ() {
        let a = Sampler::new(1, 0, 0, 0).uniform2();
        let b = Sampler::new(1, 1, 0, 0).uniform2();
        let mut s = Sampler::new(1, 0, 0, 0);
        s.uniform2();
        let c = s.uniform2();
        assert_ne!(a, b);
        assert_ne!(a, c);
        // Many samples of many pixels average to 1/2.
        let mut sum = 0.0f64;
        for p in 0..64 {
            for i in 0..64 {
                sum += f64::from(Sampler::new(3, p, 0, i).uniform());
            }
        }
        assert!((sum / 4096.0 - 0.5).abs() < 0.01);
    }
}
