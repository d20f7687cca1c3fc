//! Frames of textured scenes: pixels on textured faces are shaded in runs of [`LANES`] pixels
//! of one face, each stage over the run's lanes (coordinates and levels of detail, then
//! `filter::trilinear_lanes`: wraps, weights and mixing, then lighting and encoding), the
//! rest shaded one by one as `mod.rs` shades untextured scenes. With AVX2 and a ray table a
//! run's stages stay in registers (`colours_avx2`: hits to bytes on an unlit face of one
//! albedo without the linear plane, the usual run; `samples_of_hits`: hits to samples
//! otherwise), the same operations in the same order. The same colours as shading
//! each pixel alone (`shade`): per pixel the same look-up, lanes that give the one-lane
//! sample's bits (tested in `filter.rs`), the same lighting and encoding; only the footprint's
//! angle is taken in the camera body's frame (the face's normal turned once per face), so its
//! f32 rounding may differ, and with it, rarely, a pixel's level of detail: a linear colour's
//! last bits, or now and then an 8-bit byte.

use std::mem::MaybeUninit;
use std::ops::Range;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::filter::{LANES, Levels, Lookups, Wraps, level_of_detail, samples, trilinear_lanes};
#[cfg(target_arch = "x86_64")]
use super::filter::{levels_of_detail, stored, sums_avx2};
use super::footprint::Footprints;
#[cfg(target_arch = "x86_64")]
use super::footprint::longer_axes_in_lanes;
use super::{
    Appearance, Footprint, View, is_flat, lit, lit_by_lights, pixel_colour, shade_on, texture_of, untextured_albedo,
};
use crate::avx2::Avx2;
use crate::frame::{BACKGROUND, Frame, NO_FACE, Pixel, Plane, Planes};
#[cfg(target_arch = "x86_64")]
use crate::scene::lighting::channels_to_srgb3_avx2;
use crate::scene::lighting::linear_to_srgb3_lanes;
use crate::scene::surface::{Surface, UvMap};

/// Pixels one task shades at most: enough to fill the lanes many times over. Each task's end
/// flushes its open runs however full: at 512 pixels an omni 250² textured frame took about
/// 0.012 ms more on this AMD EPYC at one thread (docs/benchmarks.md, 2026-11-27 night2 (tex)).
const CHUNK: usize = 4096;

/// Pixels one task shades at least, where many threads share a small frame.
const CHUNK_MIN: usize = 512;

/// The pixels a task of a frame of `pixels` shades: [`CHUNK`], or fewer, down to
/// [`CHUNK_MIN`], so that every thread gets about four tasks (a 250² frame is 16 tasks of
/// 4096, which would leave most of a 16-thread pool idle, and textured pixels gather in a few
/// of them). A multiple of the lanes.
fn chunk_len(pixels: usize) -> usize {
    let per_task = pixels.div_ceil(rayon::current_num_threads() * 4);
    per_task.next_multiple_of(LANES).clamp(CHUNK_MIN, CHUNK)
}

/// Runs a chunk keeps open at once, one a textured face: a row of an omni image crosses the
/// floor, the rug and the walls in turn, and with one run each change of face shaded the run
/// it ended however few of its lanes were filled.
const OPEN_RUNS: usize = 4;

/// Shades every pixel of `frame` (traced through `view`) of a scene with textures, as
/// `shade_frame` does, lit by `lux` (by pixel index; empty for an unlit scene), filling the
/// planes `planes` asks for.
pub(super) fn shade_planes(appearance: &Appearance, lux: &[DVec3], view: View<'_>, frame: &mut Frame, planes: Planes) {
    let footprints = view.footprints();
    let pixels = frame.pixels();
    let levels: Vec<Levels<'_>> = appearance.surfaces.textures.iter().map(Levels::of).collect();
    let shader = Shader {
        appearance,
        lux,
        view: &view,
        footprints: &footprints,
        levels: &levels,
    };
    // Every pixel's colour is written once, misses too, with no fill before: a fill cost an
    // omni 250² frame about 3 instructions a pixel (callgrind, docs/benchmarks.md, 2026-11-27
    // midday (tex)), as it did the untextured frames (`eight_bit_frame`).
    let mut colour = Vec::with_capacity(pixels.len());
    let mut linear = Vec::new();
    let per_chunk = chunk_len(pixels.len());
    let chunks = pixels
        .par_chunks(per_chunk)
        .zip(colour.spare_capacity_mut()[..pixels.len()].par_chunks_mut(per_chunk))
        .enumerate();
    if planes.contains(Plane::LinearColour) {
        linear = vec![[0.0; 3]; pixels.len()];
        chunks
            .zip(linear.par_chunks_mut(per_chunk))
            .for_each(|((chunk, (hits, colour)), linear)| {
                shader.chunk(Chunk {
                    start: chunk * per_chunk,
                    hits,
                    colour,
                    linear: Some(linear),
                });
            });
    } else {
        chunks.for_each(|(chunk, (hits, colour))| {
            shader.chunk(Chunk {
                start: chunk * per_chunk,
                hits,
                colour,
                linear: None,
            });
        });
    }
    // SAFETY: the loops above wrote each of the first `pixels.len()` entries: the colour
    // chunks are zipped with the frame's pixel chunks of the same size and count, and
    // `Shader::chunk` writes every pixel of its chunk: each span of it is a miss span
    // (`fill_by_eights`), a flat span (`fill_by_eights`), another untextured span (pixel by
    // pixel), or textured pixels taken into a run, which `finish_in` writes (the slice where they
    // are neighbours, else each of `slot[..len]`) once it is full, replaced by a new face's
    // run, or flushed after the loop (every open run); a span whose face names no run or
    // untextured face (never: see the `debug_assert!`s) is written black (`fill_by_eights`). A
    // panic there unwinds past this line, leaving the length 0.
    unsafe { colour.set_len(pixels.len()) };
    frame.set_shading(planes, linear, colour);
}

/// What shading a chunk reads.
struct Shader<'a> {
    appearance: &'a Appearance,
    /// The illuminance of each lit pixel by its index in the frame (empty unlit).
    lux: &'a [DVec3],
    /// The camera and pose the frame was traced with.
    view: &'a View<'a>,
    /// Where the frame's footprints lie, in the camera body's frame.
    footprints: &'a Footprints<'a>,
    /// Each texture's levels as the lanes read them ([`Levels::of`]), by texture index.
    levels: &'a [Levels<'a>],
}

/// A textured face, and what shading its pixels reads besides their hits.
#[derive(Clone, Copy)]
struct Face<'a> {
    surface: &'a Surface,
    map: &'a UvMap,
    /// Its texture's levels, as the lanes read them.
    levels: &'a Levels<'a>,
    /// Its map's wrap, as the lanes read it.
    wraps: Wraps,
    /// Its texture's squared texels per metre (`texture_of`).
    texels_per_metre_squared: f32,
    /// Its albedo before the texture where that is the same all over (no vertex colours).
    base: Option<DVec3>,
    /// Its normal in the camera body's frame, where the footprints lie (either side: the
    /// footprint takes its angle's |cos|).
    normal: Vec3,
}

impl<'a> Face<'a> {
    /// The face `hit` (seen through `view`) lies on, whose surface is `surface`, if that has a
    /// texture (whose levels are `levels[map.texture]`).
    fn of(
        appearance: &'a Appearance,
        levels: &'a [Levels<'a>],
        view: &View<'_>,
        hit: &Pixel,
        surface: &'a Surface,
    ) -> Option<Self> {
        let map = surface.uv.as_ref()?;
        let (_, texels_per_metre_squared) = texture_of(appearance, map);
        Some(Face {
            surface,
            map,
            levels: &levels[map.texture as usize],
            wraps: Wraps::of(map.wrap),
            texels_per_metre_squared,
            base: surface
                .colours
                .is_none()
                .then(|| untextured_albedo(appearance, hit, surface)),
            normal: view.body_normal(hit.normal),
        })
    }
}

/// An untextured face: its surface (vertex colours, or none), and its byte where it is flat
/// (unlit, no surface).
#[derive(Clone, Copy)]
struct Untextured<'a> {
    surface: Option<&'a Surface>,
    flat: Option<[u8; 3]>,
}

/// A chunk of a frame as shading writes it: the index of its first pixel in the frame, its
/// hits, and its pixels' 8-bit colours, not yet written (and linear colours where asked,
/// zero before).
struct Chunk<'c> {
    start: usize,
    hits: &'c [Pixel],
    colour: &'c mut [MaybeUninit<[u8; 3]>],
    linear: Option<&'c mut [[f32; 3]]>,
}

/// Textured pixels of one face in a chunk waiting for their lanes: the face, and where each
/// pixel lies in the chunk, in rising order (`slot[..len]` rises strictly: [`Run::take`] fills
/// the free lanes with later pixels, and a run is emptied only once shaded); lanes past `len`
/// repeat earlier pixels of the face: shaded, and not written.
struct Run<'a> {
    face: Face<'a>,
    len: usize,
    slot: [usize; LANES],
}

impl Run<'_> {
    /// Moves the first pixels of `span` into the run's free lanes (as many as fit); whether
    /// the run is then full.
    #[inline(always)]
    fn take(&mut self, span: &mut Range<usize>) -> bool {
        let taken = (LANES - self.len).min(span.len());
        for (lane, slot) in self.slot[self.len..][..taken].iter_mut().zip(span.start..) {
            *lane = slot;
        }
        span.start += taken;
        self.len += taken;
        self.len == LANES
    }
}

impl<'a> Shader<'a> {
    /// Shades the hits of `chunk` into its planes, writing every pixel's colour once (pixels
    /// that hit nothing black, their linear colours left as they are, zero). The chunk is
    /// taken in spans of neighbouring pixels that see one face (most do), so that a face is
    /// compared once a pixel and looked up once a span. A span that hits nothing, or a flat
    /// face where the linear plane is not asked for, is written at once, another untextured
    /// span pixel by pixel; a textured one joins its face's run (up to [`OPEN_RUNS`] faces'
    /// runs are open at once, the oldest face's shaded to make room for a new one), and a full
    /// run (or one shaded to make room, or at the chunk's end) is shaded in lanes, coordinates
    /// to encoding, and its pixels written. Taken pixel by pixel, with the run's face, its
    /// pixels' hits and slots and the untextured face held through the loop, an equirect frame
    /// cost 9.5 M instructions more (callgrind, docs/benchmarks.md, 2026-11-26 afternoon
    /// (tex)).
    fn chunk(&self, mut chunk: Chunk<'_>) {
        let appearance = self.appearance;
        // The open runs, each with its face's id ([`NO_FACE`] for none) kept apart: comparing
        // through the `Option`s cost about 30 instructions a pixel. `oldest` is the one a new
        // face's run replaces.
        let mut runs: [Option<Run<'a>>; OPEN_RUNS] = [const { None }; OPEN_RUNS];
        let mut run_faces = [NO_FACE; OPEN_RUNS];
        let mut oldest = 0;
        // Set up afresh for each run's lanes, in place.
        let mut lookups = Lookups::empty();
        // The last untextured face seen, looked up once for its pixels, and its id.
        let mut untextured: Option<Untextured<'a>> = None;
        let mut untextured_face = NO_FACE;
        let hits = chunk.hits;
        let avx2 = Avx2::detected();
        let mut start = 0;
        while let Some(first) = hits.get(start) {
            let face_id = first.face;
            let end = span_end(hits, start);
            let mut span = start..end;
            start = end;
            if face_id == NO_FACE {
                fill_by_eights(&mut chunk.colour[span], BACKGROUND);
                continue;
            }
            let mut open = run_faces.iter().position(|&id| id == face_id);
            if open.is_none() && face_id != untextured_face {
                let surface = appearance.surfaces.of(face_id);
                if let Some(textured) =
                    surface.and_then(|surface| Face::of(appearance, self.levels, self.view, first, surface))
                {
                    if let Some(ended) = runs[oldest].as_ref().filter(|ended| ended.len > 0) {
                        self.finish(&mut chunk, ended, &mut lookups, avx2);
                    }
                    runs[oldest] = Some(Run {
                        face: textured,
                        len: 0,
                        slot: [span.start; LANES],
                    });
                    run_faces[oldest] = face_id;
                    open = Some(oldest);
                    oldest = (oldest + 1) % OPEN_RUNS;
                } else {
                    untextured = Some(Untextured {
                        surface,
                        flat: is_flat(appearance, surface).then(|| appearance.face_colours[face_id as usize]),
                    });
                    untextured_face = face_id;
                }
            }
            // The span's face is a run's (just opened, where it had none), or the untextured
            // face (just looked up, where it was another): `run_faces[k]` is only ever set with
            // `runs[k]`, and `untextured_face` with `untextured`, so neither `else` below runs
            // (`unreachable!` there cost 0.24 M instructions an omni frame and 1.15 M an
            // equirect one, callgrind).
            let Some(open) = open else {
                debug_assert!(untextured.is_some(), "face {untextured_face} names no untextured face");
                let Some(Untextured { surface, flat }) = untextured else {
                    // Written all the same, so that the chunk's every pixel is.
                    fill_by_eights(&mut chunk.colour[span], BACKGROUND);
                    continue;
                };
                // A flat face's pixels without the linear plane: its byte, the span at once
                // (pixel by pixel, as below, about 24 instructions a pixel; omni 250², half the
                // pixels: docs/benchmarks.md, 2026-11-27 midday (tex)).
                if let (Some(byte), None) = (flat, &chunk.linear) {
                    fill_by_eights(&mut chunk.colour[span], byte);
                    continue;
                }
                for slot in span {
                    let hit = &hits[slot];
                    // As `mod.rs` shades it: no texture, so no footprint.
                    let shaded = || {
                        shade_on(
                            appearance,
                            hit,
                            surface,
                            || Footprint::POINT,
                            |_| self.lux[chunk.start + slot],
                        )
                    };
                    let linear = chunk.linear.as_deref_mut().map(|linear| &mut linear[slot]);
                    chunk.colour[slot].write(pixel_colour(flat, shaded, linear));
                }
                continue;
            };
            debug_assert!(runs[open].is_some(), "face {face_id} names a run, and none is held");
            let Some(run) = runs[open].as_mut() else {
                // Written all the same, so that the chunk's every pixel is.
                fill_by_eights(&mut chunk.colour[span], BACKGROUND);
                continue;
            };
            while run.take(&mut span) {
                self.finish(&mut chunk, run, &mut lookups, avx2);
                run.len = 0;
            }
        }
        for run in runs.iter().flatten().filter(|run| run.len > 0) {
            self.finish(&mut chunk, run, &mut lookups, avx2);
        }
    }

    /// Shades the pixels of `run` in `chunk` and writes their colours, setting up `lookups`
    /// for their lanes: with AVX2 where `avx2` proves the CPU has it (the lanes' gathers, and
    /// every stage compiled for it), else portably, to the same bits. Inlined into the chunk's
    /// loop, which checks the CPU once, with the portable body out of line: a call of its own
    /// that checked the CPU and saved the registers the portable body needs cost about 33
    /// instructions a run (docs/benchmarks.md, 2026-11-27 midday (tex)).
    #[inline(always)]
    fn finish(&self, chunk: &mut Chunk<'_>, run: &Run<'a>, lookups: &mut Lookups<'a, LANES>, avx2: Option<Avx2>) {
        match avx2 {
            // Inlined into the AVX2 body, as `Avx2::run` needs, so that every stage is compiled
            // for AVX2.
            Some(avx2) => avx2.run(
                #[inline(always)]
                || self.finish_in(chunk, run, lookups, Some(avx2)),
            ),
            None => self.finish_portably(chunk, run, lookups),
        }
    }

    /// [`Shader::finish`] without AVX2.
    #[inline(never)]
    fn finish_portably(&self, chunk: &mut Chunk<'_>, run: &Run<'a>, lookups: &mut Lookups<'a, LANES>) {
        self.finish_in(chunk, run, lookups, None);
    }

    /// [`Shader::finish`]'s work over the run's lanes: on an unlit face of one albedo without
    /// the linear plane, from the hits to the bytes in AVX2 registers where the CPU has them;
    /// else stage by stage (texture coordinates and levels of detail, the filter, the
    /// lighting, the sRGB encoding), the filter's samples in registers where it can.
    #[inline(always)]
    fn finish_in(&self, chunk: &mut Chunk<'_>, run: &Run<'a>, lookups: &mut Lookups<'a, LANES>, avx2: Option<Avx2>) {
        debug_assert!(
            run.slot[..run.len].is_sorted_by(|a, b| a < b),
            "a run's slots rise strictly (the slices below rely on it): {:?}",
            &run.slot[..run.len]
        );
        let start = chunk.start;
        // A full run of neighbouring pixels (most runs): its hits are read, and its colours
        // written, as one slice, where a look-up and a store a pixel cost an equirect frame
        // about 5 M instructions (docs/benchmarks.md, 2026-11-26 afternoon (tex)). Slots rise
        // within a run, so its last is 7 past its first only where they are neighbours.
        let first = run.slot[0];
        let neighbours = run.len == LANES && run.slot[LANES - 1] == first + (LANES - 1);
        let hit: [&Pixel; LANES] = if neighbours {
            let hits = &chunk.hits[first..first + LANES];
            std::array::from_fn(|k| &hits[k])
        } else {
            std::array::from_fn(|k| &chunk.hits[run.slot[k]])
        };
        let face = &run.face;
        let (surface, map) = (face.surface, face.map);
        let appearance = self.appearance;
        let lit_here = appearance.lighting.is_some() && lit_by_lights(Some(surface));
        let index = run.slot.map(|slot| start + slot);
        // The usual run, on an unlit face of one albedo without the linear plane: from the hits
        // to the colours in AVX2 registers, where the CPU has it and the footprints are a ray
        // table's; stage by stage through memory, an omni 250² frame took about 0.03 ms more and
        // an equirect 1024×512 one about 0.25 ms (docs/benchmarks.md, 2026-11-28 (tex5)).
        // Registers only where the face's texture has level tables (only a texture built by
        // hand lacks them): else its runs go stage by stage without loading their cones twice.
        #[cfg(target_arch = "x86_64")]
        let registers = avx2.filter(|_| face.levels.in_registers());
        #[cfg(target_arch = "x86_64")]
        if !lit_here
            && chunk.linear.is_none()
            && let Some(base) = face.base
            && let Some(encoded) = self.in_registers(registers, &hit, &index, neighbours, |avx2, hits, planes| {
                // SAFETY: `avx2` proves the CPU has AVX2, which `colours_avx2` is compiled for.
                unsafe { colours_avx2(avx2, hits, planes, face, base) }
            })
        {
            write_colours(chunk, run, neighbours, &encoded);
            return;
        }
        // Else the samples in registers there, the rest stage by stage.
        #[cfg(target_arch = "x86_64")]
        let in_registers = self.in_registers(registers, &hit, &index, neighbours, |avx2, hits, planes| {
            // SAFETY: `avx2` proves the CPU has AVX2, which `samples_of_hits` is compiled for.
            unsafe { samples_of_hits(avx2, hits, planes, face) }
        });
        #[cfg(not(target_arch = "x86_64"))]
        let in_registers = None;
        let samples = in_registers.unwrap_or_else(
            #[inline(always)]
            || {
                // As `texture_point` works them out for one pixel.
                let (mut u, mut v) = ([0.0; LANES], [0.0; LANES]);
                for k in 0..LANES {
                    let uv = Surface::uv_at(map, surface.anchor, hit[k].point);
                    (u[k], v[k]) = (uv.x, uv.y);
                }
                let range = hit.map(|hit| hit.range);
                let length = self.footprints.longer_axes(&index, neighbours, &range, face.normal);
                let mut lod = [0.0; LANES];
                for k in 0..LANES {
                    lod[k] = level_of_detail(face.texels_per_metre_squared, length[k]);
                }
                samples(avx2, face.levels, face.wraps, [&u, &v], &lod).unwrap_or_else(
                    #[inline(always)]
                    || {
                        lookups.set_face(face.levels.each(), face.wraps, &u, &v, &lod, avx2);
                        trilinear_lanes(lookups, avx2)
                    },
                )
            },
        );
        // Every lane, so that the loops have a fixed length: lanes past the run's length
        // (earlier pixels of the face) are shaded and encoded, and not written. The albedo
        // times the sample channel by channel over the lanes where the face's albedo is the
        // same all over (the usual case), where a `DVec3` a lane cost an equirect frame about
        // 6 M instructions more (docs/benchmarks.md, 2026-11-26 evening (tex)).
        let mut shaded = [[0.0; 3]; LANES];
        match face.base {
            Some(base) => shaded = tinted(base, &samples, avx2),
            None => {
                for (k, shaded) in shaded.iter_mut().enumerate() {
                    let sample = DVec3::from_array(samples.map(|channel| f64::from(channel[k])));
                    *shaded = (untextured_albedo(appearance, hit[k], surface) * sample).to_array();
                }
            }
        }
        // Lit where the lights shine on the face (`lit` leaves the albedo as it is elsewhere).
        if lit_here {
            for (shaded, &slot) in shaded.iter_mut().zip(&run.slot) {
                *shaded = lit(appearance, Some(surface), DVec3::from_array(*shaded), |_| {
                    self.lux[start + slot]
                })
                .to_array();
            }
        }
        if let Some(linear) = chunk.linear.as_deref_mut() {
            for (&slot, &[red, green, blue]) in run.slot.iter().zip(&shaded).take(run.len) {
                linear[slot] = [red as f32, green as f32, blue as f32];
            }
        }
        // A textured pixel is never flat: its colour is always encoded.
        let encoded = linear_to_srgb3_lanes(&shaded, avx2);
        write_colours(chunk, run, neighbours, &encoded);
    }

    /// `work` of the run's hits `hits` (pixels `index`, `neighbours` where they follow one
    /// another) and their footprints' numbers in registers, where `avx2` is there and the
    /// footprints come from a ray table; `None` otherwise.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn in_registers<R>(
        &self,
        avx2: Option<Avx2>,
        hits: &[&Pixel; LANES],
        index: &[usize; LANES],
        neighbours: bool,
        work: impl FnOnce(Avx2, &[&Pixel; LANES], [F32x8; 7]) -> Option<R>,
    ) -> Option<R> {
        if let Some(avx2) = avx2
            && let Some(cones) = self.footprints.table()
            // SAFETY: `avx2` proves the CPU has AVX2, which `lanes_avx2` is compiled for.
            && let Some(planes) = unsafe { cones.lanes_avx2(avx2, index, neighbours) }
        {
            return work(avx2, hits, planes);
        }
        None
    }
}

/// Eight f32 lanes in an AVX2 register.
#[cfg(target_arch = "x86_64")]
type F32x8 = std::arch::x86_64::__m256;

/// Writes the colours `encoded` of `run`'s pixels in `chunk`: where they are `neighbours`,
/// one copy of the eight colours, where `copy_from_slice` of the colours mapped to
/// `MaybeUninit` cost eight 3-byte loads and stores (about 56 instructions a run,
/// docs/benchmarks.md, 2026-11-27 midday (tex)); else each of the run's pixels.
#[inline(always)]
fn write_colours(chunk: &mut Chunk<'_>, run: &Run<'_>, neighbours: bool, encoded: &[[u8; 3]; LANES]) {
    if neighbours {
        let first = run.slot[0];
        let colours = &mut chunk.colour[first..first + LANES];
        // SAFETY: `MaybeUninit<[u8; 3]>` has the layout of `[u8; 3]`, and the copy writes the
        // `LANES` colours of `colours`, a slice of that many, which does not overlap
        // `encoded`, the caller's local.
        unsafe { std::ptr::copy_nonoverlapping(encoded.as_ptr(), colours.as_mut_ptr().cast::<[u8; 3]>(), LANES) };
    } else {
        for (&slot, &encoded) in run.slot.iter().zip(encoded).take(run.len) {
            chunk.colour[slot].write(encoded);
        }
    }
}

/// The trilinear sums (red, green, blue by lane) of a run's eight hits `hits` on `face` whose
/// footprints' numbers are `planes` ([`ConePlanes::lanes_avx2`]): each hit's texture
/// coordinates ([`uv_lanes`]), range, footprint's longer axis, level of detail and filtered
/// sum in registers, the same operations in the same order as the portable lanes (the same
/// bits, tested). `None` where the face's texture has no level tables.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn sums_of_hits(hits: &[&Pixel; LANES], planes: [F32x8; 7], face: &Face<'_>) -> Option<[F32x8; 3]> {
    use std::arch::x86_64::_mm256_setr_ps;
    let uv = uv_lanes(hits, face.surface.anchor, face.map);
    let range = _mm256_setr_ps(
        hits[0].range,
        hits[1].range,
        hits[2].range,
        hits[3].range,
        hits[4].range,
        hits[5].range,
        hits[6].range,
        hits[7].range,
    );
    let length = longer_axes_in_lanes(planes, range, face.normal);
    let lod = levels_of_detail(face.texels_per_metre_squared, length);
    sums_avx2(face.levels, face.wraps, uv, lod)
}

/// [`sums_of_hits`] stored, as `samples` gives them.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn samples_of_hits(_: Avx2, hits: &[&Pixel; LANES], planes: [F32x8; 7], face: &Face<'_>) -> Option<[[f32; LANES]; 3]> {
    sums_of_hits(hits, planes, face).map(|sums| stored(sums))
}

/// The colours of a run's eight hits `hits` on an unlit `face` of albedo `base` whose
/// footprints' numbers are `planes`: [`sums_of_hits`], the albedo times each ([`tint_lanes`])
/// and their sRGB bytes, in registers by channel from the hits to the bytes: the bytes of the
/// stages one after another through memory (tested).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn colours_avx2(
    _: Avx2,
    hits: &[&Pixel; LANES],
    planes: [F32x8; 7],
    face: &Face<'_>,
    base: DVec3,
) -> Option<[[u8; 3]; LANES]> {
    let sums = sums_of_hits(hits, planes, face)?;
    Some(channels_to_srgb3_avx2(tint_lanes(base, sums)))
}

/// [`Surface::uv_at`] of each of `hits` on a face whose surface is anchored at `anchor` and
/// textured by `map`, four lanes a register: u of lanes 0–3 and 4–7, then v's; glam's
/// operations in glam's order (the difference, then each gradient's products summed x, y, z,
/// then the anchor's coordinate added), so the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn uv_lanes(hits: &[&Pixel; LANES], anchor: DVec3, map: &UvMap) -> [[std::arch::x86_64::__m256d; 2]; 2] {
    // Written out half by half: closures over the halves and axes were left calls.
    let [u_low, v_low] = uv_four(&hits[..4], anchor, map);
    let [u_high, v_high] = uv_four(&hits[4..], anchor, map);
    [[u_low, u_high], [v_low, v_high]]
}

/// [`uv_lanes`] of four hits `hits`: u, then v.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn uv_four(hits: &[&Pixel], anchor: DVec3, map: &UvMap) -> [std::arch::x86_64::__m256d; 2] {
    use std::arch::x86_64::{_mm256_add_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_setr_pd, _mm256_sub_pd};
    let [p0, p1, p2, p3] = [hits[0].point, hits[1].point, hits[2].point, hits[3].point];
    let dx = _mm256_sub_pd(_mm256_setr_pd(p0.x, p1.x, p2.x, p3.x), _mm256_set1_pd(anchor.x));
    let dy = _mm256_sub_pd(_mm256_setr_pd(p0.y, p1.y, p2.y, p3.y), _mm256_set1_pd(anchor.y));
    let dz = _mm256_sub_pd(_mm256_setr_pd(p0.z, p1.z, p2.z, p3.z), _mm256_set1_pd(anchor.z));
    let [along_u, along_v] = map.gradient;
    let dot = |g: DVec3| {
        _mm256_add_pd(
            _mm256_add_pd(
                _mm256_mul_pd(_mm256_set1_pd(g.x), dx),
                _mm256_mul_pd(_mm256_set1_pd(g.y), dy),
            ),
            _mm256_mul_pd(_mm256_set1_pd(g.z), dz),
        )
    };
    [
        _mm256_add_pd(_mm256_set1_pd(map.at_anchor.x), dot(along_u)),
        _mm256_add_pd(_mm256_set1_pd(map.at_anchor.y), dot(along_v)),
    ]
}

/// The end of the span of pixels from `start` on (a pixel of `hits`) that see its face: the
/// first later pixel that sees another, or the end of `hits`. One pixel at a time: eight faces
/// a gather took about 0.015 ms more of an omni 250² textured frame on this AMD EPYC (Zen 4;
/// docs/benchmarks.md, 2026-11-27 night2 (tex)), though fewer instructions.
#[inline(always)]
fn span_end(hits: &[Pixel], start: usize) -> usize {
    let face = hits[start].face;
    let mut end = start + 1;
    while hits.get(end).is_some_and(|hit| hit.face == face) {
        end += 1;
    }
    end
}

/// Writes `byte` into each of `colour`'s pixels, eight at a time (one 24-byte copy), where
/// LLVM's loop for one pixel at a time took seven instructions a pixel (docs/benchmarks.md,
/// 2026-11-27 midday (tex)).
#[inline(always)]
fn fill_by_eights(colour: &mut [MaybeUninit<[u8; 3]>], byte: [u8; 3]) {
    let eight = [MaybeUninit::new(byte); 8];
    let mut eights = colour.chunks_exact_mut(8);
    for pixels in &mut eights {
        pixels.copy_from_slice(&eight);
    }
    for pixel in eights.into_remainder() {
        pixel.write(byte);
    }
}

/// The albedo `base` times each lane's sample (`samples` red, green, blue by lane), by lane:
/// with `avx2` four lanes at a time and moved into lane order in registers, where LLVM's code
/// for the loop below multiplied lane by lane (about 70 instructions a run, docs/benchmarks.md,
/// 2026-11-27 morning (tex)); the same products either way.
#[inline(always)]
fn tinted(base: DVec3, samples: &[[f32; LANES]; 3], avx2: Option<Avx2>) -> [[f64; 3]; LANES] {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx2) = avx2 {
        // SAFETY: `avx2` proves the CPU has AVX2, which `tinted_avx2` is compiled for.
        return unsafe { tinted_avx2(avx2, base, samples) };
    }
    let mut shaded = [[0.0; 3]; LANES];
    for (channel, samples) in samples.iter().enumerate() {
        for (shaded, &sample) in shaded.iter_mut().zip(samples) {
            shaded[channel] = base[channel] * f64::from(sample);
        }
    }
    shaded
}

/// [`tinted`] with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn tinted_avx2(_: Avx2, base: DVec3, samples: &[[f32; LANES]; 3]) -> [[f64; 3]; LANES] {
    use std::arch::x86_64::{
        _mm256_loadu_ps, _mm256_permute2f128_pd, _mm256_storeu_pd, _mm256_unpackhi_pd, _mm256_unpacklo_pd,
    };
    // SAFETY: each load reads the eight f32 of a channel.
    let channels = tint_lanes(
        base,
        samples.map(|channel| unsafe { _mm256_loadu_ps(channel.as_ptr()) }),
    );
    let mut shaded = [[0.0; 3]; LANES];
    for (half, out) in shaded.as_flattened_mut().chunks_exact_mut(12).enumerate() {
        let [red, green, blue] = channels.map(|channel| channel[half]);
        let red_green_even = _mm256_unpacklo_pd(red, green); // r0 g0 r2 g2
        let red_green_odd = _mm256_unpackhi_pd(red, green); // r1 g1 r3 g3
        let blue_red = _mm256_unpacklo_pd(blue, red_green_odd); // b0 r1 b2 r3
        let green_blue = _mm256_unpackhi_pd(red_green_odd, blue); // g1 b1 g3 b3
        let lanes = [
            _mm256_permute2f128_pd::<0x20>(red_green_even, blue_red), // r0 g0 b0 r1
            _mm256_permute2f128_pd::<0x30>(green_blue, red_green_even), // g1 b1 r2 g2
            _mm256_permute2f128_pd::<0x31>(blue_red, green_blue),     // b2 r3 g3 b3
        ];
        for (out, lanes) in out.chunks_exact_mut(4).zip(lanes) {
            // SAFETY: the store writes four f64 of the twelve of these four lanes.
            unsafe { _mm256_storeu_pd(out.as_mut_ptr(), lanes) };
        }
    }
    shaded
}

/// The albedo `base` times each lane's sample (`sums` red, green, blue by lane) in f64, by
/// channel: lanes 0–3, then 4–7.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn tint_lanes(base: DVec3, sums: [std::arch::x86_64::__m256; 3]) -> [[std::arch::x86_64::__m256d; 2]; 3] {
    use std::arch::x86_64::{
        _mm256_castps256_ps128, _mm256_cvtps_pd, _mm256_extractf128_ps, _mm256_mul_pd, _mm256_set1_pd,
    };
    // Written out channel by channel: closures over the channels were left calls.
    let [red, green, blue] = sums;
    let (red_base, green_base, blue_base) = (_mm256_set1_pd(base.x), _mm256_set1_pd(base.y), _mm256_set1_pd(base.z));
    [
        [
            _mm256_mul_pd(red_base, _mm256_cvtps_pd(_mm256_castps256_ps128(red))),
            _mm256_mul_pd(red_base, _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(red))),
        ],
        [
            _mm256_mul_pd(green_base, _mm256_cvtps_pd(_mm256_castps256_ps128(green))),
            _mm256_mul_pd(green_base, _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(green))),
        ],
        [
            _mm256_mul_pd(blue_base, _mm256_cvtps_pd(_mm256_castps256_ps128(blue))),
            _mm256_mul_pd(blue_base, _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(blue))),
        ],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Texture coordinates of eight hits in registers: `Surface::uv_at`'s bits, lane by lane, at
    /// points near and far from the anchor, on maps with every sign of gradient, and at
    /// infinite and NaN points.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn texture_coordinates_in_registers_are_uv_at_bits() {
        let Some(avx2) = Avx2::detected() else {
            eprintln!("no AVX2 on this CPU: nothing to compare");
            return;
        };
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let odd = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -0.0,
            1e300,
            f64::MIN_POSITIVE,
        ];
        for turn in 0..2_000 {
            let scale = [1e-3, 1.0, 7.3, 1e6][turn % 4];
            let map = UvMap {
                texture: 0,
                wrap: [crate::scene::texture::Wrap::Repeat; 2],
                at_anchor: glam::DVec2::new(next() * scale, next()),
                gradient: [
                    DVec3::new(next(), next(), next()) * scale,
                    DVec3::new(next(), next(), next()) / scale,
                ],
            };
            let anchor = DVec3::new(next(), next(), next()) * scale;
            let hits: [Pixel; LANES] = std::array::from_fn(|k| Pixel {
                point: match (turn % 50, k) {
                    (0, k) => DVec3::splat(odd[k % odd.len()]),
                    _ => anchor + DVec3::new(next(), next(), next()) * 3.0,
                },
                ..Pixel::MISS
            });
            // SAFETY: `avx2` proves the CPU has AVX2.
            let lanes = unsafe { uv_of(avx2, &hits.each_ref(), anchor, &map) };
            for (k, hit) in hits.iter().enumerate() {
                let uv = Surface::uv_at(&map, anchor, hit.point);
                assert_eq!(
                    [lanes[0][k].to_bits(), lanes[1][k].to_bits()],
                    [uv.x.to_bits(), uv.y.to_bits()],
                    "turn {turn}, lane {k}"
                );
            }
        }
    }

    /// [`uv_lanes`] of `hits`, through memory: u and v by lane.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn uv_of(_: Avx2, hits: &[&Pixel; LANES], anchor: DVec3, map: &UvMap) -> [[f64; LANES]; 2] {
        let mut out = [[0.0; LANES]; 2];
        for (out, halves) in out.iter_mut().zip(uv_lanes(hits, anchor, map)) {
            for (four, half) in out.chunks_exact_mut(4).zip(halves) {
                // SAFETY: the store writes four f64 of `out`'s eight.
                unsafe { std::arch::x86_64::_mm256_storeu_pd(four.as_mut_ptr(), half) };
            }
        }
        out
    }

    /// The albedo times the samples in AVX2 registers, moved into lane order: the bits of the
    /// channel-by-channel loop, lane by lane, at zero, subnormal, small and large samples.
    #[test]
    fn tinted_in_registers_is_the_loops_bits() {
        let values = [0.0, f32::from_bits(1), 1e-30, 0.25, 0.731_2, 1.0, 3.5e20];
        for turn in 0..values.len() {
            let samples: [[f32; LANES]; 3] =
                std::array::from_fn(|channel| std::array::from_fn(|k| values[(k * 3 + channel + turn) % values.len()]));
            let base = DVec3::new(0.83, 0.131, 1.7e-3 * (turn as f64 + 1.0));
            let lanes = tinted(base, &samples, Avx2::detected());
            let by_lane = tinted(base, &samples, None);
            assert_eq!(
                lanes.map(|rgb| rgb.map(f64::to_bits)),
                by_lane.map(|rgb| rgb.map(f64::to_bits))
            );
            for (k, rgb) in by_lane.iter().enumerate() {
                for channel in 0..3 {
                    assert_eq!(rgb[channel], base[channel] * f64::from(samples[channel][k]), "lane {k}");
                }
            }
        }
    }
}
