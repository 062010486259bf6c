//! Whole renders: a budget in samples per pixel or seconds, a method, and
//! the statistics every run reports.

use crate::film::image::{Film, Image};
use crate::integrator::guide::NoGuide;
use crate::integrator::path::PathSettings;
use crate::integrator::stats::RenderCounters;
use crate::integrator::{render_pass, thread_pool};
use crate::scene::Scene;
use serde::Serialize;
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    Spp(u32),
    Seconds(f64),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Unguided path tracing.
    Pt,
}

#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub method: Method,
    pub budget: Budget,
    pub seed: u64,
    /// 0 = all cores.
    pub threads: usize,
    pub path: PathSettings,
    pub progress: bool,
}

#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    pub scene: String,
    pub method: Method,
    pub spp: u32,
    pub seconds: f64,
    pub paths_per_second: f64,
    pub rays_per_second: f64,
    pub threads: usize,
    pub seed: u64,
    pub nee: bool,
    pub max_depth: Option<u32>,
    pub width: usize,
    pub height: usize,
    pub counters: RenderCounters,
    pub mean_rgb: [f32; 3],
}

pub struct RenderResult {
    pub image: Image,
    pub film: Film,
    pub stats: RenderStats,
}

/// A progress bar on a terminal, nothing otherwise.
pub fn progress_bar(enabled: bool, len: u64, what: &str) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if !enabled || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} ({eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar.set_message(what.to_string());
    Some(bar)
}

pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<RenderResult, String> {
    let pool = thread_pool(opts.threads)?;
    let threads = pool.current_num_threads();
    let start = Instant::now();
    let (film, counters) = pool.install(|| match opts.method {
        Method::Pt => render_unguided(scene, opts, start),
    });
    let seconds = start.elapsed().as_secs_f64();
    let image = Image {
        width: film.width,
        height: film.height,
        pixels: film.mean(),
    };
    let mean = image.mean_rgb();
    let stats = RenderStats {
        scene: scene.name.clone(),
        method: opts.method,
        spp: film.spp,
        seconds,
        paths_per_second: counters.paths as f64 / seconds.max(1e-9),
        rays_per_second: (counters.rays + counters.shadow_rays) as f64 / seconds.max(1e-9),
        threads,
        seed: opts.seed,
        nee: opts.path.nee,
        max_depth: opts.path.max_depth,
        width: film.width,
        height: film.height,
        counters,
        mean_rgb: mean.to_array(),
    };
    Ok(RenderResult { image, film, stats })
}

fn render_unguided(scene: &Scene, opts: &RenderOptions, start: Instant) -> (Film, RenderCounters) {
    let mut film = Film::new(scene.camera.width, scene.camera.height);
    let mut counters = RenderCounters::default();
    let (len, deadline) = match opts.budget {
        Budget::Spp(n) => (n as u64, None),
        Budget::Seconds(s) => ((s * 1000.0) as u64, Some(s)),
    };
    let bar = progress_bar(opts.progress, len, "pt");
    let mut pass = 0u64;
    loop {
        match (opts.budget, deadline) {
            (Budget::Spp(n), _) if pass >= n as u64 => break,
            (_, Some(s)) if start.elapsed().as_secs_f64() >= s && pass > 0 => break,
            _ => {}
        }
        let out = render_pass(scene, &NoGuide, &opts.path, opts.seed, pass);
        film.merge(&out.film);
        counters.add(&out.counters);
        pass += 1;
        if let Some(b) = &bar {
            match deadline {
                Some(_) => b.set_position((start.elapsed().as_secs_f64() * 1000.0) as u64),
                None => b.set_position(pass),
            }
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    (film, counters)
}
