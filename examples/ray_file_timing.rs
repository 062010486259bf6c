//! Per-ray traversal speed on a fixed set of rays, for comparing our BVH
//! with another renderer's on identical rays (`scripts/mitsuba_rays.py`
//! writes the rays with Mitsuba 3 and times Embree on them).
//!
//! Usage: `cargo run --release --example ray_file_timing -- SCENE.xml RAYS.bin [REPEAT]`
//!
//! The ray file is little-endian: the 8 bytes `LTCRAYS1`, the ray count n
//! (u32) and the occlusion length (f32), then seven planes of n f32 each:
//! origin x, y, z, direction x, y, z, and the other renderer's closest-hit
//! distance (+∞ for a miss). Prints one line of `key=value` pairs: closest-hit
//! and occlusion rays per second (best of REPEAT passes, one thread), and
//! the share of rays whose closest hit agrees with the file's distance.

use glam::Vec3;
use ltcguide::scene::load_scene;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

struct RayFile {
    origins: Vec<Vec3>,
    directions: Vec<Vec3>,
    their_t: Vec<f32>,
    occlusion_tmax: f32,
}

fn read_rays(path: &Path) -> Result<RayFile, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let bad = |why: &str| format!("{}: not a ray file ({why})", path.display());
    if bytes.len() < 16 || &bytes[..8] != b"LTCRAYS1" {
        return Err(bad("no LTCRAYS1 header"));
    }
    let n = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    let occlusion_tmax = f32::from_le_bytes(bytes[12..16].try_into().unwrap());
    if bytes.len() != 16 + 28 * n {
        return Err(bad(&format!("{} bytes for {n} rays", bytes.len())));
    }
    if occlusion_tmax.is_nan() || occlusion_tmax <= 0.0 {
        return Err(bad("occlusion length not positive"));
    }
    let values: Vec<f32> = bytes[16..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let plane = |k: usize| &values[k * n..(k + 1) * n];
    let vec = |k: usize, i: usize| Vec3::new(plane(k)[i], plane(k + 1)[i], plane(k + 2)[i]);
    let mut origins = Vec::with_capacity(n);
    let mut directions = Vec::with_capacity(n);
    for i in 0..n {
        let (o, d) = (vec(0, i), vec(3, i));
        if !o.is_finite() || !d.is_finite() || d.length_squared() == 0.0 {
            return Err(bad(&format!("ray {i} is not finite or has no direction")));
        }
        origins.push(o);
        directions.push(d.normalize());
    }
    Ok(RayFile {
        origins,
        directions,
        their_t: plane(6).to_vec(),
        occlusion_tmax,
    })
}

fn run(args: &[String]) -> Result<String, String> {
    let [scene_path, rays_path, rest @ ..] = args else {
        return Err("usage: ray_file_timing SCENE.xml RAYS.bin [REPEAT]".into());
    };
    let repeat: usize = match rest.first() {
        Some(r) => r
            .parse()
            .ok()
            .filter(|&r| r > 0)
            .ok_or(format!("REPEAT must be a positive integer, not {r:?}"))?,
        None => 5,
    };
    let scene = load_scene(Path::new(scene_path)).map_err(|e| e.to_string())?;
    let rays = read_rays(Path::new(rays_path))?;
    let n = rays.origins.len();
    let accel = &scene.accel;
    let (mut best_closest, mut best_occluded) = (f64::MAX, f64::MAX);
    let mut agree = 0usize;
    for pass in 0..repeat {
        let start = Instant::now();
        let mut hits = Vec::with_capacity(n);
        for (&o, &d) in rays.origins.iter().zip(&rays.directions) {
            hits.push(accel.closest_hit(o, d, 0.0, f32::INFINITY).map(|h| h.t));
        }
        best_closest = best_closest.min(start.elapsed().as_secs_f64());
        let start = Instant::now();
        let mut blocked = 0usize;
        for (&o, &d) in rays.origins.iter().zip(&rays.directions) {
            blocked += accel.occluded(o, d, 0.0, rays.occlusion_tmax) as usize;
        }
        best_occluded = best_occluded.min(start.elapsed().as_secs_f64());
        std::hint::black_box(blocked);
        if pass == 0 {
            agree = hits
                .iter()
                .zip(&rays.their_t)
                .filter(|&(ours, &theirs)| match ours {
                    Some(t) => (t - theirs).abs() <= 1e-3 * theirs.abs().max(1.0),
                    None => !theirs.is_finite(),
                })
                .count();
        }
    }
    Ok(format!(
        "rays={n} closest_per_s={:.0} occluded_per_s={:.0} agree={:.4}",
        n as f64 / best_closest,
        n as f64 / best_occluded,
        agree as f64 / n.max(1) as f64
    ))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(line) => {
            println!("{line}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("ray_file_timing: {e}");
            ExitCode::from(2)
        }
    }
}
