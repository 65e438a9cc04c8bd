//! `cargo bench -p orch-metamodel --bench kriging_scale`: Kriging at 30–300 runs on
//! two standard test functions, beside scikit-learn on the same points when it is
//! installed (`python3 -c "import sklearn"`; Debian: `apt-get install
//! python3-sklearn`), else the crate's figures alone.
//!
//! - Branin (2 factors) and Hartmann-6 (6 factors), each on a maximin Latin hypercube
//!   of n runs in the coded box, noise-free.
//! - Held-out RMSE on 2000 seeded uniform points, the maximised log-likelihood, the
//!   length scales and the fit time (median of 3), for the squared-exponential and
//!   Matérn 5/2 kernels, constant trend, a fitted nugget.
//! - scikit-learn: `GaussianProcessRegressor` with a constant times the same kernel
//!   (anisotropic length scales) plus a white-noise kernel, `normalize_y=True`, 8
//!   restarts of L-BFGS-B, on the same points and test points.

use std::io::Write;
use std::process::Command;
use std::time::Instant;

use orch_metamodel::{Design, DesignKind, Kernel, Kriging, KrigingOptions, Nugget, Trend};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Branin on coded [−1, 1]²: x₁ ∈ [−5, 10], x₂ ∈ [0, 15].
fn branin(c: &[f64]) -> f64 {
    let x1 = -5.0 + 7.5 * (c[0] + 1.0);
    let x2 = 7.5 * (c[1] + 1.0);
    let pi = std::f64::consts::PI;
    let b = 5.1 / (4.0 * pi * pi);
    let t = 1.0 / (8.0 * pi);
    (x2 - b * x1 * x1 + 5.0 / pi * x1 - 6.0).powi(2) + 10.0 * (1.0 - t) * x1.cos() + 10.0
}

/// Hartmann-6 on coded [−1, 1]⁶ (the unit cube).
fn hartmann6(c: &[f64]) -> f64 {
    const ALPHA: [f64; 4] = [1.0, 1.2, 3.0, 3.2];
    const A: [[f64; 6]; 4] = [
        [10.0, 3.0, 17.0, 3.5, 1.7, 8.0],
        [0.05, 10.0, 17.0, 0.1, 8.0, 14.0],
        [3.0, 3.5, 1.7, 10.0, 17.0, 8.0],
        [17.0, 8.0, 0.05, 10.0, 0.1, 14.0],
    ];
    const P: [[f64; 6]; 4] = [
        [0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886],
        [0.2329, 0.4135, 0.8307, 0.3736, 0.1004, 0.9991],
        [0.2348, 0.1451, 0.3522, 0.2883, 0.3047, 0.6650],
        [0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381],
    ];
    let x: Vec<f64> = c.iter().map(|v| 0.5 * (v + 1.0)).collect();
    -(0..4)
        .map(|i| {
            let s: f64 = (0..6).map(|j| A[i][j] * (x[j] - P[i][j]).powi(2)).sum();
            ALPHA[i] * (-s).exp()
        })
        .sum::<f64>()
}

struct Case {
    name: &'static str,
    f: fn(&[f64]) -> f64,
    k: usize,
}

/// The first Python (`python3` on PATH, then the system's) that imports scikit-learn.
fn python_with_sklearn() -> Option<&'static str> {
    ["python3", "/usr/bin/python3"].into_iter().find(|python| {
        Command::new(python)
            .args(["-c", "import sklearn"])
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// scikit-learn's held-out RMSE, log-likelihood and fit seconds on the same data.
fn sklearn(
    python: &str,
    kernel: Kernel,
    x: &[Vec<f64>],
    y: &[f64],
    test: &[Vec<f64>],
    truth: &[f64],
) -> Option<(f64, f64, f64)> {
    let dir = std::env::temp_dir().join(format!("orch-kriging-scale-{}", std::process::id()));
    std::fs::create_dir_all(&dir).ok()?;
    let write = |name: &str, rows: &[Vec<f64>]| {
        let mut file = std::fs::File::create(dir.join(name)).unwrap();
        for row in rows {
            let line: Vec<String> = row.iter().map(|v| format!("{v:.17e}")).collect();
            writeln!(file, "{}", line.join(",")).unwrap();
        }
    };
    write("x.csv", x);
    write("y.csv", &y.iter().map(|v| vec![*v]).collect::<Vec<_>>());
    write("t.csv", test);
    write("u.csv", &truth.iter().map(|v| vec![*v]).collect::<Vec<_>>());
    let script =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/sklearn_reference.py");
    let kernel = match kernel {
        Kernel::SquaredExponential => "se",
        Kernel::Matern52 => "matern52",
    };
    let output = Command::new(python)
        .arg(script)
        .arg(&dir)
        .arg(kernel)
        .output()
        .ok()?;
    let _ = std::fs::remove_dir_all(&dir);
    if !output.status.success() {
        eprintln!(
            "scikit-learn failed: {}",
            String::from_utf8_lossy(&output.stderr)
        );
        return None;
    }
    let text = String::from_utf8_lossy(&output.stdout);
    let v: Vec<f64> = text
        .split_whitespace()
        .filter_map(|s| s.parse().ok())
        .collect();
    (v.len() == 3).then(|| (v[0], v[1], v[2]))
}

fn main() {
    let python = python_with_sklearn();
    if python.is_none() {
        println!("scikit-learn not found (python3 -c 'import sklearn'): the crate's figures alone");
    }
    let cases = [
        Case {
            name: "Branin",
            f: branin,
            k: 2,
        },
        Case {
            name: "Hartmann-6",
            f: hartmann6,
            k: 6,
        },
    ];
    println!(
        "{:<11} {:>4} {:<7} {:>11} {:>9} {:>9}   {:>11} {:>9} {:>9}   {:>6} {:>6}",
        "function",
        "n",
        "kernel",
        "rmse",
        "loglik",
        "fit s",
        "sk rmse",
        "sk loglik",
        "sk fit s",
        "rmse×",
        "speed×"
    );
    for case in &cases {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let test: Vec<Vec<f64>> = (0..2000)
            .map(|_| (0..case.k).map(|_| rng.random_range(-1.0..=1.0)).collect())
            .collect();
        let truth: Vec<f64> = test.iter().map(|p| (case.f)(p)).collect();
        for n in [30usize, 100, 300] {
            let x = Design::build(
                &DesignKind::LatinHypercube {
                    samples: n,
                    seed: 3,
                    candidates: 20,
                },
                case.k,
            )
            .unwrap()
            .points;
            let y: Vec<f64> = x.iter().map(|p| (case.f)(p)).collect();
            for kernel in [Kernel::SquaredExponential, Kernel::Matern52] {
                let options = KrigingOptions {
                    kernel,
                    trend: Trend::Constant,
                    nugget: Nugget::Fitted,
                    ..KrigingOptions::default()
                };
                let mut times = Vec::new();
                let mut model = None;
                for _ in 0..3 {
                    let start = Instant::now();
                    model = Some(Kriging::fit(&x, &y, &options).unwrap());
                    times.push(start.elapsed().as_secs_f64());
                }
                times.sort_by(f64::total_cmp);
                let model = model.unwrap();
                let rmse = (test
                    .iter()
                    .zip(&truth)
                    .map(|(p, t)| (model.predict(p) - t).powi(2))
                    .sum::<f64>()
                    / test.len() as f64)
                    .sqrt();
                let kernel_name = match kernel {
                    Kernel::SquaredExponential => "sq-exp",
                    Kernel::Matern52 => "matern",
                };
                let reference = python.and_then(|p| sklearn(p, kernel, &x, &y, &test, &truth));
                let (sk, ratios) = match reference {
                    Some((r, l, t)) => (
                        format!("{r:>11.3e} {l:>9.2} {t:>9.3}"),
                        format!("{:>6.2} {:>6.2}", rmse / r, t / times[1]),
                    ),
                    None => (format!("{:>11} {:>9} {:>9}", "-", "-", "-"), String::new()),
                };
                println!(
                    "{:<11} {:>4} {:<7} {:>11.3e} {:>9.2} {:>9.3}   {sk}   {ratios}",
                    case.name,
                    n,
                    kernel_name,
                    rmse,
                    model.log_likelihood(),
                    times[1],
                );
            }
        }
    }
}
