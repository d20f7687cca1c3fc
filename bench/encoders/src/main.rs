//! Best and median ms of encoding one RGB8 PNG with fast deflate (fdeflate, as omnisim's
//! `png_encoder`) under each row filter, and of SHA-256 over 975 kB (one omni data-set frame's
//! bytes), the variants alternated in each round so that the machine's load falls on all alike.
//!
//! Usage: encoders IMAGE.png [ROUNDS]

use image::ImageEncoder;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use sha2::Digest;
use std::time::Instant;

const FILTERS: [(&str, FilterType); 5] = [
    ("adaptive", FilterType::Adaptive),
    ("up", FilterType::Up),
    ("sub", FilterType::Sub),
    ("paeth", FilterType::Paeth),
    ("none", FilterType::NoFilter),
];

/// One data-set frame's bytes (colour PNG, range EXR, PLY of a 250² omni frame).
const FRAME_BYTES: usize = 975_000;

fn best_and_median(mut ms: Vec<f64>) -> (f64, f64) {
    ms.sort_by(f64::total_cmp);
    (ms[0], ms[ms.len() / 2])
}

fn timed(ms: &mut Vec<f64>, work: impl FnOnce()) {
    let start = Instant::now();
    work();
    ms.push(start.elapsed().as_secs_f64() * 1e3);
}

fn main() {
    let mut args = std::env::args().skip(1);
    let path = args.next().expect("usage: encoders IMAGE.png [ROUNDS]");
    let rounds: usize = args.next().map_or(400, |s| s.parse().expect("ROUNDS is a count"));
    let image = image::open(&path).expect("IMAGE.png opens").to_rgb8();
    let (width, height) = image.dimensions();
    let mut png_ms = vec![Vec::new(); FILTERS.len()];
    let mut png_bytes = [0; FILTERS.len()];
    let mut sha_ms = Vec::new();
    let mut encoded = Vec::new();
    let frame: Vec<u8> = (0..FRAME_BYTES as u32)
        .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8)
        .collect();
    for _ in 0..rounds {
        for (k, (_, filter)) in FILTERS.iter().enumerate() {
            encoded.clear();
            timed(&mut png_ms[k], || {
                PngEncoder::new_with_quality(&mut encoded, CompressionType::Fast, *filter)
                    .write_image(image.as_raw(), width, height, image::ExtendedColorType::Rgb8)
                    .expect("encodes");
            });
            png_bytes[k] = encoded.len();
        }
        timed(&mut sha_ms, || {
            std::hint::black_box(sha2::Sha256::digest(std::hint::black_box(&frame)));
        });
    }
    println!("{path} ({width}x{height}), {rounds} rounds");
    for (k, (name, _)) in FILTERS.iter().enumerate() {
        let (best, median) = best_and_median(png_ms[k].clone());
        println!(
            "png {name:9} {:7} B  best {best:.3} ms  median {median:.3} ms",
            png_bytes[k]
        );
    }
    let (best, median) = best_and_median(sha_ms);
    let gbs = FRAME_BYTES as f64 / best / 1e6;
    println!("sha256 {FRAME_BYTES} B  best {best:.3} ms ({gbs:.2} GB/s)  median {median:.3} ms");
}
