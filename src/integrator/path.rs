//! The one path loop shared by every method: unidirectional path tracing
//! with optional next-event estimation (MIS, power heuristic), Mitsuba's
//! `max_depth` semantics, Russian roulette, and an optional guide mixed with
//! BSDF sampling by one-sample MIS.

use super::deferred_pdf::DeferredPdf;
use super::guide::{Guide, GuideVertex, PathVertex, VertexContext};
use super::stats::RenderCounters;
use crate::emitter::LightSample;
use crate::math::{Spectrum, is_finite3};
use crate::sampling::{Rng, power_heuristic};
use crate::scene::{Interaction, Scene};
use glam::Vec3;

/// How paths are terminated early.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum RouletteMode {
    /// Mitsuba's rule: from depth 5 on, survive with min(max(throughput)·η², 0.95).
    Classic,
    /// Adjoint-driven (Vorba & Křivánek 2016), needs a guide with adjoint estimates.
    Adrrs,
    Off,
}

#[derive(Clone, Copy, Debug)]
pub struct PathSettings {
    pub nee: bool,
    /// Maximum number of segments (camera ray included), `None` = unlimited.
    pub max_depth: Option<u32>,
    pub roulette: RouletteMode,
    /// ADRRS's window ratio s (upper/lower bound; the paper's is
    /// [`PAPER_WINDOW`](crate::guiding::adrrs::PAPER_WINDOW)). A wider
    /// window kills fewer paths: less time saved, less variance added.
    pub adrrs_window: f32,
    /// The guide's pdf of a BSDF sample at a path's first guided vertex is
    /// computed only if the path brings radiance (`super::deferred_pdf`);
    /// off: always at once. Without NEE only. The estimator is the same
    /// either way; roulette reads a stand-in meanwhile.
    pub defer_guide_pdf: bool,
}

/// Depth from which classic roulette applies (Mitsuba's `rr_depth`).
const RR_DEPTH: u32 = 5;

/// Path length (segments) from which adjoint-driven roulette applies.
const ADRRS_MIN_SEGMENTS: u32 = 2;

/// Per-thread scratch reused across paths.
pub struct PathScratch {
    pub vertices: Vec<PathVertex>,
    /// (number of vertices that precede the contribution, contribution)
    contributions: Vec<(usize, Spectrum)>,
    /// Index of the pass the current path belongs to (for its records).
    pub pass: u64,
}

impl Default for PathScratch {
    fn default() -> Self {
        PathScratch {
            vertices: Vec::with_capacity(16),
            contributions: Vec::with_capacity(16),
            pass: 0,
        }
    }
}

/// Offsets a ray origin off a surface, to the side the ray leaves towards.
#[inline]
pub fn spawn_origin(scene: &Scene, p: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
    let eps = scene.ray_epsilon(p);
    if ng.dot(dir) >= 0.0 {
        p + ng * eps
    } else {
        p - ng * eps
    }
}

/// A light sample with its direction in the shading frame and, once the
/// shadow ray has been traced, whether it reached the light.
struct NeeSample {
    ls: LightSample,
    wi: Vec3,
    visible: Option<bool>,
}

/// Draws the next-event sample at `it`. Its shadow ray is traced at once
/// where the BSDF can reflect (wo and wi on one side of the
/// shading surface: every BSDF with a non-delta lobe reflects only), so it
/// overlaps the texel fetches of the BSDF lookup that follows; the rare
/// sample the BSDF then rejects wasted a ray, not the image. Always
/// inlined: returned through memory, the sample was reloaded in wider
/// pieces than it was stored in, a store-forwarding stall per vertex.
#[inline(always)]
fn nee_sample(
    scene: &Scene,
    it: &Interaction,
    wo: Vec3,
    rng: &mut Rng,
    counters: &mut RenderCounters,
) -> Option<NeeSample> {
    let u_sel = rng.next_f32();
    let u_light = rng.next_2d();
    let origin = |dir| spawn_origin(scene, it.p, it.ng, dir);
    let ls = scene.lights.sample(it.p, origin, u_sel, u_light)?;
    let wi = it.frame.to_local(ls.wi);
    let visible = (wi.z * wo.z > 0.0).then(|| shadow_ray_clear(scene, &ls, counters));
    Some(NeeSample { ls, wi, visible })
}

/// True when nothing blocks the shadow ray of `ls`.
#[inline]
fn shadow_ray_clear(scene: &Scene, ls: &LightSample, counters: &mut RenderCounters) -> bool {
    // The sample is aimed from the offset origin at the sampled point itself.
    let tmax = ls.dist * (1.0 - 1e-4);
    counters.shadow_rays += 1;
    tmax > 0.0 && !scene.occluded_except(ls.origin, ls.wi, tmax, ls.prim)
}

/// Where a contribution goes: after a deferred guide pdf, to the sum the
/// pdf will rescale.
#[inline]
fn accumulator<'a>(
    radiance: &'a mut Spectrum,
    deferred_radiance: &'a mut Spectrum,
    deferring: bool,
) -> &'a mut Spectrum {
    if deferring {
        deferred_radiance
    } else {
        radiance
    }
}

/// Estimates the radiance arriving at the camera along (o, d).
#[allow(clippy::too_many_arguments)]
pub fn trace_path<G: Guide>(
    scene: &Scene,
    guide: &G,
    settings: &PathSettings,
    mut o: Vec3,
    mut d: Vec3,
    rng: &mut Rng,
    counters: &mut RenderCounters,
    scratch: &mut PathScratch,
    recorder: &mut G::Recorder,
    cache: &mut G::Cache,
    pixel_estimate: f32,
) -> Spectrum {
    let learning = guide.learning();
    scratch.vertices.clear();
    scratch.contributions.clear();
    let max_depth = settings.max_depth.unwrap_or(u32::MAX);
    let mut radiance = Spectrum::ZERO;
    // What arrived after a deferred guide pdf, in the stand-in's units.
    let mut deferred_radiance = Spectrum::ZERO;
    let mut deferred: Option<DeferredPdf<G::Location>> = None;
    let may_defer = settings.defer_guide_pdf && !settings.nee;
    let mut throughput = Spectrum::ONE;
    // State of the previous scattering event, for MIS on emitter hits.
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    let mut prev_p = o;
    let mut segments = 1u32;
    let mut eta_scale = 1.0f32;
    counters.paths += 1;

    let add = |c: Spectrum, scratch: &mut PathScratch, radiance: &mut Spectrum| {
        *radiance += c;
        if learning {
            scratch.contributions.push((scratch.vertices.len(), c));
        }
    };

    loop {
        counters.rays += 1;
        let Some(it) = scene.intersect(o, d, f32::INFINITY) else {
            if !scene.lights.is_empty() {
                let le = scene.lights.eval_infinite(d);
                if le != Spectrum::ZERO {
                    let w = if prev_delta || !settings.nee {
                        1.0
                    } else {
                        power_heuristic(prev_pdf, scene.lights.pdf_infinite(d))
                    };
                    add(
                        throughput * le * w,
                        scratch,
                        accumulator(&mut radiance, &mut deferred_radiance, deferred.is_some()),
                    );
                }
            }
            break;
        };

        // The texels of the hit's material load while the emission, the
        // light sample and the shadow ray are computed.
        let material = scene.material_of(&it);
        material.prefetch(it.uv);

        // Emission of the surface we hit.
        if let Some(light) = scene.shapes[it.shape as usize].light {
            let le = scene.lights.emitted(light, it.frame.n, -d);
            if le != Spectrum::ZERO {
                let w = if prev_delta || !settings.nee {
                    1.0
                } else {
                    power_heuristic(prev_pdf, scene.lights.pdf_area(light, prev_p, it.p, it.ng))
                };
                add(
                    throughput * le * w,
                    scratch,
                    accumulator(&mut radiance, &mut deferred_radiance, deferred.is_some()),
                );
            }
        }
        if segments >= max_depth {
            break;
        }
        if material.reflects_nothing() {
            counters.ended_at_black_surfaces += 1;
            break;
        }
        // The guide's memory, too, loads during the texture lookup.
        let smooth_only = material.has_smooth_lobes_only();
        let location = (!smooth_only).then(|| guide.locate(it.p));

        let wo = it.frame.to_local(-d);
        let nee = settings.nee && !smooth_only && !scene.lights.is_empty();
        // Next-event sample and shadow ray ahead of the texture lookup.
        let early_nee = nee.then(|| nee_sample(scene, &it, wo, rng, counters));
        let bsdf = material.at(it.uv);
        debug_assert_eq!(bsdf.has_smooth_lobes_only(), smooth_only);

        // Adjoint-driven roulette plays at this vertex (given estimates).
        let adrrs_here = settings.roulette == RouletteMode::Adrrs && segments >= ADRRS_MIN_SEGMENTS;
        // Next-event estimation at vertices with a non-delta component.
        let mut guide_vertex = None;
        if let Some(location) = location {
            guide_vertex = guide.vertex(
                &VertexContext {
                    p: it.p,
                    ng: it.ng,
                    frame: &it.frame,
                    wo_local: wo,
                    bsdf: &bsdf,
                    needs_adjoint: adrrs_here,
                    vertex_index: segments - 1,
                    revisit: false,
                },
                location,
                cache,
                counters,
            );
        }
        // Next-event estimation, MIS-weighted against the mixture: its
        // reflected radiance (throughput left out), added after roulette.
        let mut nee_reflected = None;
        if let Some(NeeSample { ls, wi, visible }) = early_nee.flatten() {
            // One evaluation for both: rough plastic computes them together.
            let (f, pdf_bsdf) = bsdf.eval_pdf_counted(wo, wi, &mut counters.bsdf_nonfinite);
            if f != Spectrum::ZERO
                && visible.unwrap_or_else(|| shadow_ray_clear(scene, &ls, counters))
            {
                let mut pdf_scatter = pdf_bsdf;
                if let Some(g) = guide_vertex.as_mut() {
                    let a = g.bsdf_fraction();
                    pdf_scatter = a * pdf_scatter + (1.0 - a) * g.pdf(ls.wi);
                }
                let w = power_heuristic(ls.pdf, pdf_scatter);
                nee_reflected = Some(f * ls.radiance * (w / ls.pdf));
            }
        }
        // Adjoint-driven roulette (Vorba & Křivánek 2016): the expected
        // contribution of everything from this vertex on is throughput ×
        // reflected radiance; keep it near the pixel's value.
        let mut adrrs_applied = false;
        if adrrs_here
            && let Some(tree_adjoint) = guide_vertex.as_ref().and_then(|g| g.adjoint_estimate())
            // With NEE the tree learns what emitter hits bring after their MIS
            // weight; the rest of the direct light is NEE's, whose one-sample
            // estimate completes the reflected radiance (without it the
            // adjoint fell short wherever lights are small, and roulette
            // played too often: 4× classic's relMSE in 0.53× its time on a
            // Cornell box, against 1.4× in 0.73× with it).
            && let adjoint = tree_adjoint + nee_reflected.map_or(0.0, crate::math::luminance)
            && crate::guiding::adrrs::usable_estimates(pixel_estimate, adjoint, &mut counters.adrrs)
        {
            adrrs_applied = true;
            let t = crate::math::luminance(throughput);
            match (crate::guiding::adrrs::Adrrs {
                s: settings.adrrs_window,
            })
            .roulette(
                t,
                pixel_estimate,
                adjoint,
                rng.next_f32(),
                &mut counters.adrrs,
            ) {
                Some(factor) => throughput *= factor,
                None => break,
            }
        }
        if let Some(c) = nee_reflected {
            add(
                throughput * c,
                scratch,
                accumulator(&mut radiance, &mut deferred_radiance, deferred.is_some()),
            );
        }

        // Choose the next direction: guide or BSDF, one-sample MIS.
        let u_choice = rng.next_f32();
        let u_lobe = rng.next_f32();
        let u_dir = rng.next_2d();
        let (wi_world, weight, pdf_mix, is_delta, eta, pdf_bsdf, pdf_guide, alpha, f_value);
        let has_guide = guide_vertex.is_some();
        match guide_vertex.as_mut() {
            Some(g) if u_choice >= g.bsdf_fraction() => {
                let a = g.bsdf_fraction();
                counters.guided_samples += 1;
                let Some((dir, pg)) = g.sample(u_dir) else {
                    counters.invalid_scattering += 1;
                    break;
                };
                let wi = it.frame.to_local(dir);
                // One evaluation for both: rough plastic computes them together.
                let (f, pb) = bsdf.eval_pdf_counted(wo, wi, &mut counters.bsdf_nonfinite);
                let p = a * pb + (1.0 - a) * pg;
                if !(p > 0.0 && p.is_finite()) {
                    counters.invalid_scattering += 1;
                    break;
                }
                if f == Spectrum::ZERO {
                    // Guided into a direction the BSDF does not reflect to
                    // (e.g. below the horizon): a valid zero-valued sample.
                    // It still counts in the tree's statistical weight N,
                    // or F/(N·Ω) would overstate the mean radiance by the
                    // share of such samples (18–25 % on a glossy panel),
                    // and with it ADRRS's adjoint. Adam skips it: its
                    // gradient is exactly 0, and a step on it would only
                    // move θ by momentum.
                    counters.guided_below_horizon += (wi.z * wo.z <= 0.0) as u64;
                    if learning {
                        scratch.vertices.push(PathVertex {
                            p: it.p,
                            dir,
                            radiance: Spectrum::ZERO,
                            throughput: Spectrum::ZERO,
                            bsdf_value: Spectrum::ZERO,
                            pdf_mix: p,
                            pdf_bsdf: pb,
                            pdf_guide: pg,
                            bsdf_fraction: a,
                            learned_share: g.learned_share(),
                            recorded: true,
                            delta: false,
                            guide_used: false,
                            throughput_pdf: crate::math::luminance(throughput) * p,
                            depth: scratch.vertices.len() as u32,
                        });
                    }
                    break;
                }
                (wi_world, weight, pdf_mix, is_delta, eta) = (dir, f / p, p, false, 1.0);
                (pdf_bsdf, pdf_guide, alpha, f_value) = (pb, pg, a, f);
            }
            _ => {
                let Some(s) = bsdf.sample_counted(wo, u_lobe, u_dir, &mut counters.bsdf_nonfinite)
                else {
                    break;
                };
                if !(s.pdf > 0.0 && s.pdf.is_finite() && is_finite3(s.weight)) {
                    counters.invalid_scattering += 1;
                    break;
                }
                let dir = it.frame.to_world(s.wi);
                if s.is_delta {
                    // At a guided vertex (smooth plastic's coat) BSDF sampling
                    // was chosen with probability α, and the guide never
                    // proposes a delta direction, so the sample's probability
                    // is α·p_lobe. `render` refuses α = 0 where a guided BSDF
                    // has a delta lobe, since that lobe would never be sampled.
                    // For Adam, f_value is the lobe's mass (weight × lobe
                    // probability), so that f·L/p_mix is the sample's F/p as
                    // for a solid-angle sample.
                    let a = guide_vertex.as_ref().map_or(1.0, |g| g.bsdf_fraction());
                    (wi_world, weight, pdf_mix, is_delta, eta) =
                        (dir, s.weight / a, a * s.pdf, true, s.eta);
                    (pdf_bsdf, pdf_guide, alpha, f_value) = (s.pdf, 0.0, a, s.weight * s.pdf);
                } else if let Some(g) = guide_vertex.as_mut() {
                    let a = g.bsdf_fraction();
                    let defer_at = location.filter(|_| may_defer && deferred.is_none());
                    // The guide's part of a deferred mixture stands at 0.
                    let pg = if defer_at.is_some() { 0.0 } else { g.pdf(dir) };
                    let p = a * s.pdf + (1.0 - a) * pg;
                    if let Some(location) = defer_at {
                        counters.guide_pdfs_deferred += 1;
                        // Its own context rather than the guide's call's
                        // above: one shared context, built before that
                        // call, cost radiance guiding 1–6 % of its CPU
                        // (staircase, 16 spp, 6 side-by-side pairs).
                        let ctx = VertexContext {
                            p: it.p,
                            ng: it.ng,
                            frame: &it.frame,
                            wo_local: wo,
                            bsdf: &bsdf,
                            needs_adjoint: false,
                            vertex_index: segments - 1,
                            revisit: false,
                        };
                        deferred = Some(DeferredPdf::new(
                            &ctx,
                            location,
                            dir,
                            a,
                            s.pdf,
                            throughput,
                            scratch.vertices.len(),
                        ));
                    }
                    let f = s.weight * s.pdf;
                    (wi_world, weight, pdf_mix, is_delta, eta) = (dir, f / p, p, false, s.eta);
                    (pdf_bsdf, pdf_guide, alpha, f_value) = (s.pdf, pg, a, f);
                } else {
                    (wi_world, weight, pdf_mix, is_delta, eta) =
                        (dir, s.weight, s.pdf, false, s.eta);
                    (pdf_bsdf, pdf_guide, alpha, f_value) = (s.pdf, 0.0, 1.0, s.weight * s.pdf);
                }
            }
        }
        let throughput_before = throughput;
        throughput *= weight;
        eta_scale *= eta * eta;
        if learning {
            let depth = scratch.vertices.len() as u32;
            scratch.vertices.push(PathVertex {
                p: it.p,
                dir: wi_world,
                radiance: Spectrum::ZERO,
                throughput,
                bsdf_value: f_value,
                pdf_mix,
                pdf_bsdf,
                pdf_guide,
                bsdf_fraction: alpha,
                learned_share: guide_vertex.as_ref().map_or(0.0, |g| g.learned_share()),
                // Delta samples at a guided vertex are samples of its
                // mixture too: they count in N, and they tell Adam what
                // BSDF sampling buys there (Müller 2019 keeps them; without
                // them a smooth-plastic coat drove α to its floor and the
                // variance up tenfold).
                recorded: location.is_some(),
                delta: is_delta,
                guide_used: has_guide,
                throughput_pdf: crate::math::luminance(throughput_before) * pdf_mix,
                depth,
            });
        }
        if throughput == Spectrum::ZERO {
            break;
        }
        prev_pdf = pdf_mix;
        prev_delta = is_delta;
        prev_p = it.p;
        o = spawn_origin(scene, it.p, it.ng, wi_world);
        d = wi_world;
        segments += 1;

        // Classic Russian roulette (also where ADRRS had no estimates).
        match settings.roulette {
            RouletteMode::Off => {}
            RouletteMode::Classic | RouletteMode::Adrrs => {
                if segments > RR_DEPTH && !adrrs_applied {
                    let q = (throughput.max_element() * eta_scale).min(0.95);
                    match crate::sampling::roulette(q, rng.next_f32()) {
                        Some(factor) => throughput *= factor,
                        None => break,
                    }
                }
            }
        }
    }

    if let Some(d) = deferred
        && deferred_radiance != Spectrum::ZERO
    {
        counters.guide_pdfs_resolved += 1;
        match d.resolve(guide, cache, counters) {
            Some((pdf_guide, pdf_mix)) => {
                let factor = d.rescale(pdf_mix);
                radiance += deferred_radiance * factor;
                if learning {
                    d.fix_records(
                        &mut scratch.vertices,
                        &mut scratch.contributions,
                        factor,
                        pdf_guide,
                        pdf_mix,
                    );
                }
            }
            None => {
                counters.invalid_scattering += 1;
                d.drop_later(&mut scratch.contributions);
            }
        }
    } else {
        radiance += deferred_radiance;
    }
    if !is_finite3(radiance) || radiance.min_element() < 0.0 {
        counters.nonfinite_samples += 1;
        return Spectrum::ZERO;
    }
    if learning && !scratch.vertices.is_empty() {
        for &(count, c) in &scratch.contributions {
            for v in &mut scratch.vertices[..count] {
                let t = v.throughput;
                v.radiance += Spectrum::new(
                    if t.x > 0.0 { c.x / t.x } else { 0.0 },
                    if t.y > 0.0 { c.y / t.y } else { 0.0 },
                    if t.z > 0.0 { c.z / t.z } else { 0.0 },
                );
            }
        }
        guide.record(recorder, &scratch.vertices, scratch.pass);
    }
    radiance
}
