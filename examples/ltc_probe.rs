use glam::{DMat3, DVec3};
use ltcguide::ltc::fit::*;
use ltcguide::ltc::ggx;
fn main() {
    let opts = FitOptions::default();
    // (t, a, m00, m20, m11, m02)
    let rows = [
        (56usize, 25usize, 0.469288, 0.856632, 0.294460, -3.552818),
        (35, 25, 0.325849, 0.332225, 0.311080, -1.164883),
        (17, 10, 0.050401, 0.022727, 0.050401, -0.451195),
        (56, 10, 0.054622, 0.280648, 0.050011, -5.631547),
    ];
    for (t, a, m00, m20, m11, m02) in rows {
        let theta = t as f64 / 63.0 * 1.57079;
        let alpha = ((a as f64 / 63.0).powi(2)).max(1e-4);
        let m = DMat3::from_cols(
            DVec3::new(m00, 0.0, m20),
            DVec3::new(0.0, m11, 0.0),
            DVec3::new(m02, 0.0, 1.0),
        );
        let wo = wo_of_cos(theta.cos());
        let (rho, _) = ggx::albedo(alpha, wo, 64);
        let eh = l1_error(m, alpha, wo, rho, 64, 0.37);
        let mut best = f64::MAX;
        for start in [
            [(0.5f64).ln(), (0.5f64).ln(), 0.0],
            [alpha.ln(), alpha.ln(), 0.0],
            [m00.ln(), m11.ln(), 0.0],
        ] {
            let fit = fit_node(alpha, theta.cos(), start, &opts);
            let e = l1_error(fit.params.matrix(), alpha, wo, rho, 64, 0.37);
            println!("  start {start:?} -> {:?} err {e:.4}", fit.params);
            best = best.min(e);
        }
        println!(
            "t {t} a {a} alpha {alpha:.4} theta {:.1}: heitz {eh:.4} ours(best) {best:.4}",
            theta.to_degrees()
        );
    }
}
