//! Counters gathered per thread and summed: work done and every guard that
//! fired. A guard that fires is never silent: its count reaches the stats.

use serde::Serialize;

#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct RenderCounters {
    pub paths: u64,
    pub rays: u64,
    pub shadow_rays: u64,
    /// Path contributions that were NaN/Inf/negative and were replaced by zero.
    pub nonfinite_samples: u64,
    /// BSDF or guide samples with a non-finite or non-positive pdf/weight.
    pub invalid_scattering: u64,
    /// BSDF evaluations and samples whose value, pdf or direction was NaN
    /// or Inf (zeroed or rejected by the BSDF layer).
    pub bsdf_nonfinite: u64,
    /// Guide vertices left to BSDF sampling because the guide's weights at
    /// the root, or their total, were NaN or Inf.
    pub guide_root_nonfinite: u64,
    /// Times the guide (not the BSDF) was asked for a direction; one that
    /// could not be drawn also counts in `invalid_scattering`.
    pub guided_samples: u64,
    /// Guided samples whose direction fell on the wrong side of the surface.
    pub guided_below_horizon: u64,
    /// First vertices whose product lobe was reused from an earlier path of
    /// the pixel / built anew (product guiding with reuse in a pixel).
    pub product_lobes_reused: u64,
    pub product_lobes_built: u64,
    /// Paths ended at a surface that reflects nothing
    /// ([`crate::bsdf::Material::reflects_nothing`]), after its emission.
    pub ended_at_black_surfaces: u64,
    /// BSDF samples whose guide pdf was left for the path's end, and those
    /// of them whose path brought radiance, so that it was computed
    /// (`super::deferred_pdf`).
    pub guide_pdfs_deferred: u64,
    pub guide_pdfs_resolved: u64,
    /// Adjoint-driven roulette decisions.
    #[serde(flatten)]
    pub adrrs: AdrrsCounters,
}

/// Serialisable mirror of the ADRRS counters.
pub type AdrrsCounters = crate::guiding::adrrs::AdrrsStats;

impl RenderCounters {
    pub fn add(&mut self, o: &RenderCounters) {
        self.paths += o.paths;
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.nonfinite_samples += o.nonfinite_samples;
        self.invalid_scattering += o.invalid_scattering;
        self.bsdf_nonfinite += o.bsdf_nonfinite;
        self.guide_root_nonfinite += o.guide_root_nonfinite;
        self.guided_samples += o.guided_samples;
        self.guided_below_horizon += o.guided_below_horizon;
        self.product_lobes_reused += o.product_lobes_reused;
        self.product_lobes_built += o.product_lobes_built;
        self.ended_at_black_surfaces += o.ended_at_black_surfaces;
        self.guide_pdfs_deferred += o.guide_pdfs_deferred;
        self.guide_pdfs_resolved += o.guide_pdfs_resolved;
        self.adrrs.merge(&o.adrrs);
    }
}
