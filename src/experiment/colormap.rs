//! False-colour maps for error images and AOVs.

/// A perceptually ordered map (a 5-stop approximation of viridis), t ∈ [0, 1].
pub fn viridis(t: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 5] = [
        [0.267, 0.005, 0.329],
        [0.230, 0.322, 0.546],
        [0.128, 0.567, 0.551],
        [0.369, 0.789, 0.383],
        [0.993, 0.906, 0.144],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * (STOPS.len() - 1) as f32;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f32;
    let c = |k: usize| ((STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f) * 255.0 + 0.5) as u8;
    [c(0), c(1), c(2)]
}

/// Maps values to colours on a log scale between `lo` and `hi`.
pub fn log_scale_rgb(values: &[f32], lo: f32, hi: f32) -> Vec<u8> {
    let (llo, lhi) = (lo.max(1e-12).ln(), hi.max(lo * 1.0001).ln());
    values
        .iter()
        .flat_map(|&v| viridis(((v.max(1e-12)).ln() - llo) / (lhi - llo)))
        .collect()
}

/// Maps values in [0, 1] linearly.
pub fn linear_rgb(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|&v| viridis(v)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints_and_monotone_brightness() {
        assert_eq!(viridis(0.0), [68, 1, 84]);
        assert_eq!(viridis(1.0), [253, 231, 37]);
        assert_eq!(viridis(f32::NAN), viridis(0.0));
        let lum = |c: [u8; 3]| 0.2126 * c[0] as f32 + 0.7152 * c[1] as f32 + 0.0722 * c[2] as f32;
        let mut last = -1.0;
        for k in 0..=20 {
            let l = lum(viridis(k as f32 / 20.0));
            assert!(l > last);
            last = l;
        }
    }
}
