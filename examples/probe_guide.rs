//! Diagnostic: how close is a trained radiance guide to the incident
//! radiance it should learn, at the first hit of one pixel?
//! Usage: probe_guide SCENE X Y SPP
use glam::Vec2;
use ltcguide::directional::square_to_dir;
use ltcguide::guiding::descent::{RadianceWeights, pdf_direction};
use ltcguide::integrator::guide::NoGuide;
use ltcguide::integrator::path::{
    PathScratch, PathSettings, RouletteMode, spawn_origin, trace_path,
};
use ltcguide::integrator::stats::RenderCounters;
use ltcguide::math::luminance;
use ltcguide::render::{Budget, Method, RenderOptions, render};
use ltcguide::sampling::Rng;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let scene = ltcguide::scene::load_scene(std::path::Path::new(&a[1])).unwrap();
    let (x, y): (f32, f32) = (a[2].parse().unwrap(), a[3].parse().unwrap());
    let spp: u32 = a[4].parse().unwrap();
    let settings = PathSettings {
        nee: false,
        max_depth: Some(10),
        roulette: RouletteMode::Off,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    };
    let opts = RenderOptions {
        method: Method::Radiance,
        budget: Budget::Spp(spp),
        seed: 1,
        threads: 2,
        path: settings,
        snapshot_times: vec![],
        use_plan: false,
        ..Default::default()
    };
    let res = render(&scene, &opts).unwrap();
    let tree = res.tree.unwrap();
    let (o, d) = scene.camera.ray(Vec2::new(x, y));
    let it = scene.intersect(o, d, f32::INFINITY).unwrap();
    let n = it.frame.n * it.frame.n.dot(-d).signum();
    let leaf = tree.leaf(tree.lookup(it.p));
    println!(
        "hit p={:?} n={:?} leaf size={:?} alpha={}",
        it.p,
        n,
        leaf.size,
        tree.bsdf_fraction(tree.lookup(it.p))
    );
    const G: usize = 32;
    let per = 64;
    let mut li = vec![0f64; G * G];
    let mut guide = vec![0f64; G * G];
    let mut rng = Rng::new(7, 3);
    let mut counters = RenderCounters::default();
    let mut scratch = PathScratch::default();
    let mut rec = ();
    let nee = PathSettings {
        nee: true,
        max_depth: Some(9),
        roulette: RouletteMode::Off,
        adrrs_window: ltcguide::guiding::adrrs::PAPER_WINDOW,
        defer_guide_pdf: true,
    };
    for c in 0..G * G {
        let (cx, cy) = (c % G, c / G);
        for _ in 0..per {
            let u = (Vec2::new(cx as f32, cy as f32) + rng.next_2d()) / G as f32;
            let w = square_to_dir(u);
            guide[c] += pdf_direction(&leaf.sampling, &mut RadianceWeights, w) as f64 / per as f64;
            if w.dot(n) <= 0.0 {
                continue;
            }
            let org = spawn_origin(&scene, it.p, it.ng, w);
            let l = trace_path(
                &scene,
                &NoGuide,
                &nee,
                org,
                w,
                &mut rng,
                &mut counters,
                &mut scratch,
                &mut rec,
                &mut (),
                0.0,
            );
            li[c] += luminance(l) as f64 * w.dot(n) as f64 / per as f64;
        }
    }
    let dw = 4.0 * std::f64::consts::PI / (G * G) as f64;
    let total: f64 = li.iter().sum::<f64>() * dw;
    // Relative second moment of f·cos·L/p for a diffuse surface (f=1/π drops out):
    let moment = |p: &dyn Fn(usize) -> f64| -> f64 {
        (0..G * G)
            .filter(|&c| li[c] > 0.0)
            .map(|c| li[c] * li[c] / p(c) * dw)
            .sum::<f64>()
            / (total * total)
    };
    let cos_pdf = |c: usize| {
        let (cx, cy) = (c % G, c / G);
        let w = square_to_dir((Vec2::new(cx as f32, cy as f32) + 0.5) / G as f32);
        (w.dot(n).max(1e-4) / std::f32::consts::PI) as f64
    };
    let alpha = tree.bsdf_fraction(tree.lookup(it.p)) as f64;
    println!(
        "irradiance {total:.4}; relative 2nd moment: cosine {:.3}, guide {:.3}, mix(learned a) {:.3}, ideal 1",
        moment(&cos_pdf),
        moment(&|c| guide[c].max(1e-12)),
        moment(&|c| alpha * cos_pdf(c) + (1.0 - alpha) * guide[c])
    );
    let below: f64 = (0..G * G)
        .filter(|&c| {
            let (cx, cy) = (c % G, c / G);
            square_to_dir((Vec2::new(cx as f32, cy as f32) + 0.5) / G as f32).dot(n) <= 0.0
        })
        .map(|c| guide[c] * dw)
        .sum();
    println!("guide mass below horizon {below:.3}");
    let shade = |v: f64, m: f64| {
        let s = b" .:-=+*#%@";
        let i = ((v / m).sqrt() * 9.0).round() as usize;
        s[i.min(9)] as char
    };
    let ml = li.iter().cloned().fold(0.0, f64::max);
    let mg = guide.iter().cloned().fold(0.0, f64::max);
    for cy in 0..G {
        let l: String = (0..G).map(|cx| shade(li[cy * G + cx], ml)).collect();
        let g: String = (0..G).map(|cx| shade(guide[cy * G + cx], mg)).collect();
        println!("{l}   {g}");
    }
}
