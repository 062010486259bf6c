//! Regenerates `data/ltc_ggx.bin` until the CLI exposes `fit-ltc`:
//! `cargo run --release --example fit_ltc -- [resolution] [threads] [out_dir]`.
use ltcguide::ltc::fit::{FitOptions, run_fit};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mut opts = FitOptions {
        verbose: true,
        ..FitOptions::default()
    };
    if let Some(r) = args.get(1) {
        opts.resolution = r.parse().expect("resolution");
    }
    if let Some(t) = args.get(2) {
        opts.threads = t.parse().expect("threads");
    }
    if let Some(d) = args.get(3) {
        opts.out_dir = d.into();
    }
    match run_fit(&opts) {
        Ok(r) => println!("{r:#?}"),
        Err(e) => {
            eprintln!("fit-ltc failed: {e}");
            std::process::exit(1);
        }
    }
}
