//! The one display encoding of the viewer: linear values in the image's own units become 8-bit
//! display values the same way for pre-rendered and live pixels, in the window and in PNG
//! screenshots. `shaders/encode.wgsl` is the GPU side; [`DisplayEncoding::encode`] is the same
//! arithmetic on the CPU (the reference the tests hold the shader to, and what makes the
//! unchanged pre-rendered pixels of a float image).
//!
//! `byte = clamp(floor(255 * transfer(max(v, 0)) + 1/2 + a * (2 u - 1)), 0, 255)` per channel,
//! where `transfer` is sRGB's or `x^(1/gamma)`, `a` the dither amplitude in steps (RenderMan
//! `Quantize`'s default 0.5 for float images, 0 for images that are already 8-bit) and `u` a
//! hash of the pixel and channel in `[0, 1)`, so a frame is the same every time it is drawn.
//! NaN becomes 0.

/// How linear values become display values before quantisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DisplayTransfer {
    /// `x^(1/gamma)` (`Gamma(1.0)` passes values through).
    Gamma(f32),
    /// The sRGB transfer function (IEC 61966-2-1), as image viewers show float images.
    Srgb,
}

/// The display encoding: transfer function and dither.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisplayEncoding {
    pub transfer: DisplayTransfer,
    /// Dither amplitude in quantisation steps (0 = none).
    pub dither: f32,
}

/// Dither amplitude for float images: RenderMan's `Quantize` default.
pub const FLOAT_IMAGE_DITHER: f32 = 0.5;

impl DisplayEncoding {
    /// The encoding of an 8-bit image whose bytes were decoded with `gamma`: its exact inverse,
    /// no dither, so unchanged pixels come back byte for byte.
    pub fn for_8bit_image(gamma: f32) -> DisplayEncoding {
        DisplayEncoding { transfer: DisplayTransfer::Gamma(sane_gamma(gamma)), dither: 0.0 }
    }

    /// The encoding of a float image under the RIB's `Exposure` gamma: sRGB when the RIB leaves
    /// gamma at 1 (what EXR viewers show), else the RIB's gamma in its place; dithered.
    pub fn for_float_image(gamma: f32) -> DisplayEncoding {
        let gamma = sane_gamma(gamma);
        let transfer = if gamma == 1.0 { DisplayTransfer::Srgb } else { DisplayTransfer::Gamma(gamma) };
        DisplayEncoding { transfer, dither: FLOAT_IMAGE_DITHER }
    }

    /// The shader's parameters: `[1 / gamma, 1 if sRGB, dither amplitude, 0]`.
    pub fn shader_parameters(&self) -> [f32; 4] {
        match self.transfer {
            DisplayTransfer::Gamma(g) => [1.0 / g, 0.0, self.dither, 0.0],
            DisplayTransfer::Srgb => [1.0, 1.0, self.dither, 0.0],
        }
    }

    /// The display value of linear `v` before quantisation, in `[0, 1]` (NaN stays NaN).
    pub fn transfer(&self, v: f32) -> f32 {
        let v = v.max(0.0);
        let display = match self.transfer {
            DisplayTransfer::Gamma(g) => {
                if g == 1.0 {
                    v
                } else {
                    v.powf(1.0 / g)
                }
            }
            DisplayTransfer::Srgb => {
                if v <= 0.003_130_8 {
                    12.92 * v
                } else {
                    1.055 * v.powf(1.0 / 2.4) - 0.055
                }
            }
        };
        display.min(1.0)
    }

    /// The 8-bit value of channel `channel` (0..3) of pixel `(x, y)` of an image `width` wide.
    pub fn encode(&self, v: f32, x: u32, y: u32, width: u32, channel: u32) -> u8 {
        let display = self.transfer(v);
        if display.is_nan() {
            return 0;
        }
        let noise = if self.dither > 0.0 {
            self.dither * (2.0 * dither_noise(x, y, width, channel) - 1.0)
        } else {
            0.0
        };
        (display * 255.0 + 0.5 + noise).floor().clamp(0.0, 255.0) as u8
    }
}

/// A gamma that can be inverted: RenderMan's `Exposure` gamma, with non-positive or non-finite
/// values taken as 1 (the ray tracer's writer does the same).
fn sane_gamma(gamma: f32) -> f32 {
    if gamma > 0.0 && gamma.is_finite() { gamma } else { 1.0 }
}

/// PCG's output hash of a 32-bit state (Jarzynski & Olano 2020), as `encode.wgsl` computes it.
fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The dither's uniform value in `[0, 1)` for a pixel's channel: 24 bits, exact in `f32`.
pub fn dither_noise(x: u32, y: u32, width: u32, channel: u32) -> f32 {
    let index = y.wrapping_mul(width).wrapping_add(x).wrapping_mul(4).wrapping_add(channel);
    (pcg_hash(index) >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eight_bit_encoding_inverts_its_decoding_for_every_byte() {
        for gamma in [1.0f32, 2.2, 1.8, 0.45] {
            let e = DisplayEncoding::for_8bit_image(gamma);
            for b in 0..=255u8 {
                let linear = (f64::from(b) / 255.0).powf(f64::from(gamma)) as f32;
                assert_eq!(e.encode(linear, 3, 4, 10, 1), b, "gamma {gamma} byte {b}");
            }
        }
    }

    #[test]
    fn srgb_matches_its_definition_and_clamps() {
        let e = DisplayEncoding::for_float_image(1.0);
        assert_eq!(e.transfer, DisplayTransfer::Srgb);
        assert!((e.transfer(0.5) - 0.735_356_6).abs() < 1e-6);
        assert!((e.transfer(0.002) - 0.025_84).abs() < 1e-6);
        assert_eq!(e.transfer(7.0), 1.0);
        assert_eq!(e.transfer(-1.0), 0.0);
        assert_eq!(e.encode(f32::NAN, 0, 0, 1, 0), 0);
        assert_eq!(DisplayEncoding::for_float_image(2.2).transfer, DisplayTransfer::Gamma(2.2));
        assert_eq!(DisplayEncoding::for_float_image(-3.0).transfer, DisplayTransfer::Srgb);
    }

    #[test]
    fn dither_is_unbiased_and_deterministic() {
        // A value a third of the way between two steps: the dithered mean is that value.
        let e = DisplayEncoding { transfer: DisplayTransfer::Gamma(1.0), dither: 0.5 };
        let v = (100.0 + 1.0 / 3.0) / 255.0;
        let (w, h) = (256u32, 256u32);
        let mut sum = 0.0f64;
        for y in 0..h {
            for x in 0..w {
                let b = e.encode(v, x, y, w, 0);
                assert!(b == 100 || b == 101);
                sum += f64::from(b);
            }
        }
        let mean = sum / f64::from(w * h);
        assert!((mean - (100.0 + 1.0 / 3.0)).abs() < 0.01, "mean {mean}");
        assert_eq!(e.encode(v, 17, 9, w, 2), e.encode(v, 17, 9, w, 2));
        let u: Vec<f32> = (0..4).map(|c| dither_noise(5, 6, 7, c)).collect();
        assert!(u.iter().all(|&u| (0.0..1.0).contains(&u)));
        assert!(u.windows(2).all(|p| p[0] != p[1]));
    }
}
