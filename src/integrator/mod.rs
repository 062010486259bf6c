//! Rendering: passes of one sample per pixel over the whole image, in
//! parallel over blocks of rows, reproducible for a seed (each pixel of each
//! pass owns its own random stream, so the image does not depend on the
//! thread count or scheduling).

pub mod deferred_pdf;
pub mod first_vertex;
pub mod guide;
pub mod path;
pub mod stats;

use crate::film::image::Film;
use crate::sampling::Rng;
use crate::scene::Scene;
use glam::Vec2;
use guide::{Guide, VertexCache};
use path::{PathScratch, PathSettings, trace_path};
use rayon::prelude::*;
use stats::RenderCounters;

/// Rows per parallel work item: small enough to balance 2–64 threads, large
/// enough to amortise scheduling and keep record buffers few.
const ROWS_PER_BLOCK: usize = 4;

/// The result of rendering some passes.
pub struct PassOutput {
    pub film: Film,
    pub counters: RenderCounters,
}

/// Mixes a seed and a pass index into a stream seed (SplitMix64 finaliser).
fn pass_seed(seed: u64, pass: u64) -> u64 {
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15u64.wrapping_mul(pass + 1));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Renders the passes `passes` (1 spp each over the image, pixel-major, see
/// [`render_passes_into`]) into a film of their own, and the learning
/// records into `recorders`. Must run inside the caller's rayon pool.
pub fn render_passes<G: Guide>(
    scene: &Scene,
    guide: &G,
    settings: &PathSettings,
    seed: u64,
    passes: std::ops::Range<u64>,
    pixel_estimates: Option<&[f32]>,
    recorders: &mut Vec<G::Recorder>,
) -> PassOutput {
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let counters = render_passes_into(
        scene,
        guide,
        settings,
        seed,
        passes,
        pixel_estimates,
        &mut film,
        recorders,
    );
    PassOutput { film, counters }
}

/// Renders the passes `passes` and adds them straight into `film`. Each
/// worker accumulates its own rows: no per-pass image to allocate (page
/// faults), add and merge on one thread while the other waits.
///
/// A pixel's samples of all the passes are traced one after the other, so
/// consecutive paths start alike and find the BVH nodes, triangles and
/// texels of their first hits in cache; a pass-major order had evicted
/// them by the next pass. Every sample keeps its pass's random stream and
/// the film adds the passes in order, so the image is the same as from
/// one pass at a time.
///
/// `recorders` ends with one buffer of learning records per row block, in
/// image order. Its buffers are emptied and refilled rather than made
/// anew, so that a caller that keeps them across calls reuses their memory.
#[allow(clippy::too_many_arguments)]
pub fn render_passes_into<G: Guide>(
    scene: &Scene,
    guide: &G,
    settings: &PathSettings,
    seed: u64,
    passes: std::ops::Range<u64>,
    pixel_estimates: Option<&[f32]>,
    film: &mut Film,
    recorders: &mut Vec<G::Recorder>,
) -> RenderCounters {
    let (w, h) = (scene.camera.width, scene.camera.height);
    assert_eq!((film.width, film.height), (w, h), "film and camera differ");
    let stream_seeds: Vec<u64> = passes.clone().map(|p| pass_seed(seed, p)).collect();
    let block_len = ROWS_PER_BLOCK * w;
    let blocks = film.sum.len().div_ceil(block_len);
    recorders.truncate(blocks);
    recorders.resize_with(blocks, || guide.new_recorder());
    let results: Vec<RenderCounters> = film
        .sum
        .par_chunks_mut(block_len)
        .zip(film.sum_sq.par_chunks_mut(block_len))
        .zip(recorders.par_iter_mut())
        .enumerate()
        // One job per block. Rayon otherwise splits the blocks into about
        // two runs per thread and cannot split a run once it has started,
        // so a run of costly rows kept one thread busy while the others
        // idled: with 2 threads, each idled 5.4 % of a 16-spp radiance
        // render of staircase (2.3 % after, scene setup included; session
        // 49).
        .with_max_len(1)
        .map_init(
            || (PathScratch::default(), G::Cache::default()),
            |(scratch, cache), (block, ((sum, sum_sq), recorder))| {
                let mut counters = RenderCounters::default();
                guide.clear_recorder(recorder);
                for (k, (s, q)) in sum.iter_mut().zip(sum_sq.iter_mut()).enumerate() {
                    let index = block * block_len + k;
                    let (x, y) = (index % w, index / w);
                    for (&stream_seed, pass) in stream_seeds.iter().zip(passes.clone()) {
                        scratch.pass = pass;
                        let mut rng = Rng::new(stream_seed, index as u64);
                        let film_pos = Vec2::new(x as f32, y as f32) + rng.next_2d();
                        let (o, d) = scene.camera.ray(film_pos);
                        let v = trace_path(
                            scene,
                            guide,
                            settings,
                            o,
                            d,
                            &mut rng,
                            &mut counters,
                            scratch,
                            recorder,
                            cache,
                            pixel_estimates.map_or(0.0, |e| e[index]),
                        );
                        crate::film::image::add_sample(s, q, v);
                    }
                }
                // The block's pixels share the cache in their fixed order;
                // it is forgotten before the worker takes another block.
                cache.end_block(&mut counters);
                counters
            },
        )
        .collect();
    film.spp += stream_seeds.len() as u32;
    let mut counters = RenderCounters::default();
    for c in &results {
        counters.add(c);
    }
    counters
}

/// Builds the thread pool a render runs in (0 = all cores).
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool, String> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| format!("cannot start {threads} threads: {e}"))
}
