//! Seeded procedural patterns, baked at load into ordinary textures (one sampling path for
//! images and patterns); a scene file writes them as a texture's [`Pattern`] (`file.rs`).
//! Every pattern tiles: one repeat is the unit square of texture
//! coordinates, and its edges meet its opposite edges, so `Repeat` shows no seams.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub use super::file::Pattern;
use super::file::Rgb;
use super::texture::Texture;

/// Largest baked pattern side, texels.
pub const MAX_PATTERN_TEXELS: u32 = 4096;

impl Pattern {
    /// The pattern baked into a `texels × texels` texture with its mips.
    pub fn bake(&self, texels: u32) -> Result<Texture, String> {
        if !(1..=MAX_PATTERN_TEXELS).contains(&texels) {
            return Err(format!(
                "texels must be between 1 and {MAX_PATTERN_TEXELS}, not {texels}"
            ));
        }
        let count = |what: &str, n: u32| {
            if (1..=texels).contains(&n) {
                Ok(n)
            } else {
                Err(format!("{what} must be between 1 and texels ({texels}), not {n}"))
            }
        };
        let colour_at: Box<dyn Fn(f64, f64) -> [u8; 3]> = match *self {
            Pattern::Checker { colours, squares } => {
                let n = f64::from(count("squares", squares)?);
                Box::new(move |u, v| {
                    let odd = ((u * n).floor() + (v * n).floor()) as i64 % 2 == 1;
                    rgb(if odd { colours.1 } else { colours.0 })
                })
            }
            Pattern::Bricks {
                brick,
                mortar,
                rows,
                columns,
                seed,
            } => {
                let (rows, columns) = (count("rows", rows)?, count("columns", columns)?);
                let mut random = ChaCha8Rng::seed_from_u64(seed);
                let shades: Vec<f64> = (0..rows * columns).map(|_| random.random_range(0.8..1.15)).collect();
                Box::new(move |u, v| {
                    let y = v * f64::from(rows);
                    let row = y.floor() as u32 % rows;
                    let x = u * f64::from(columns) + if row % 2 == 1 { 0.5 } else { 0.0 };
                    let column = x.floor() as u32 % columns;
                    // Mortar: 8 % of a course high, 4 % of a brick wide, on each brick's top and left.
                    if y.fract() < 0.08 || x.fract() < 0.04 {
                        return rgb(mortar);
                    }
                    scaled(brick, shades[(row * columns + column) as usize])
                })
            }
            Pattern::Wood {
                light,
                dark,
                rings,
                seed,
            } => {
                let rings = f64::from(count("rings", rings)?);
                let noise = ValueNoise::new(seed, 4);
                Box::new(move |u, v| {
                    let phase = rings * u + 0.6 * noise.at(u, v);
                    let grain = 0.5 + 0.5 * (std::f64::consts::TAU * phase).cos();
                    mix(light, dark, grain * grain)
                })
            }
            Pattern::Noise { low, high, cells, seed } => {
                let noise = ValueNoise::new(seed, count("cells", cells)?);
                let fine = ValueNoise::new(seed.wrapping_add(1), (cells * 2).min(texels));
                Box::new(move |u, v| mix(low, high, (0.7 * noise.at(u, v) + 0.3 * fine.at(u, v)).clamp(0.0, 1.0)))
            }
        };
        let side = f64::from(texels);
        let pixels: Vec<[u8; 3]> = (0..texels * texels)
            .map(|i| {
                let (x, y) = (i % texels, i / texels);
                colour_at((f64::from(x) + 0.5) / side, (f64::from(y) + 0.5) / side)
            })
            .collect();
        Ok(Texture::from_rgb(texels, texels, &pixels))
    }
}

fn rgb(c: Rgb) -> [u8; 3] {
    [c.0, c.1, c.2]
}

fn scaled(c: Rgb, factor: f64) -> [u8; 3] {
    rgb(c).map(|k| (f64::from(k) * factor).round().clamp(0.0, 255.0) as u8)
}

/// `a` where `t` = 0, `b` where `t` = 1 (in sRGB values: patterns are pictures, not light).
fn mix(a: Rgb, b: Rgb, t: f64) -> [u8; 3] {
    let (a, b) = (rgb(a), rgb(b));
    [0, 1, 2].map(|k| (f64::from(a[k]) + (f64::from(b[k]) - f64::from(a[k])) * t).round() as u8)
}

/// Tiling value noise: random values on a `cells × cells` lattice that wraps around,
/// interpolated with a smoothstep.
struct ValueNoise {
    cells: u32,
    lattice: Vec<f64>,
}

impl ValueNoise {
    fn new(seed: u64, cells: u32) -> Self {
        let mut random = ChaCha8Rng::seed_from_u64(seed);
        Self {
            cells,
            lattice: (0..cells * cells).map(|_| random.random::<f64>()).collect(),
        }
    }

    /// The noise at (u, v) of one repeat, in [0, 1].
    fn at(&self, u: f64, v: f64) -> f64 {
        let n = self.cells;
        let (x, y) = (u * f64::from(n), v * f64::from(n));
        let (x0, y0) = (x.floor(), y.floor());
        let smooth = |t: f64| t * t * (3.0 - 2.0 * t);
        let (fx, fy) = (smooth(x - x0), smooth(y - y0));
        let value = |i: f64, j: f64| {
            let (i, j) = ((i as i64).rem_euclid(i64::from(n)), (j as i64).rem_euclid(i64::from(n)));
            self.lattice[(j * i64::from(n) + i) as usize]
        };
        let top = value(x0, y0) + (value(x0 + 1.0, y0) - value(x0, y0)) * fx;
        let bottom = value(x0, y0 + 1.0) + (value(x0 + 1.0, y0 + 1.0) - value(x0, y0 + 1.0)) * fx;
        top + (bottom - top) * fy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_checker_has_its_squares_and_patterns_repeat_with_their_seed() {
        let checker = Pattern::Checker {
            colours: ((0, 0, 0), (255, 255, 255)),
            squares: 4,
        }
        .bake(16)
        .unwrap();
        let level = &checker.levels[0];
        assert_eq!(level.texel(0, 0), [0; 3]);
        assert_eq!(level.texel(4, 0), [255; 3]);
        assert_eq!(level.texel(4, 4), [0; 3]);
        let wood = |seed| {
            Pattern::Wood {
                light: (200, 150, 100),
                dark: (100, 60, 30),
                rings: 6,
                seed,
            }
            .bake(64)
            .unwrap()
        };
        assert_eq!(wood(3), wood(3));
        assert_ne!(wood(3), wood(4));
        let bad = Pattern::Checker {
            colours: ((0, 0, 0), (1, 1, 1)),
            squares: 0,
        };
        assert!(bad.bake(16).unwrap_err().contains("squares"));
        assert!(bad.bake(100_000).unwrap_err().contains("texels"));
    }
}
