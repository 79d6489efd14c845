//! The convergence study end to end on a tiny budget: a CSV with the documented header,
//! errors that fall, fitted slopes near -1/2 for unbiased strategies and a bias floor for
//! the grid, a Markdown table, and plots that decode.

mod common;

use std::collections::BTreeMap;
use std::process::Command;

/// Least-squares slope of ln(rmse) against ln(seconds) over waves from 4 spp on.
fn slope(points: &[(f64, u32, f64)]) -> f64 {
    let pts: Vec<(f64, f64)> = points.iter().filter(|p| p.1 >= 4).map(|p| (p.0.ln(), p.2.ln())).collect();
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    sxy / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>()
}

#[test]
fn a_tiny_study_writes_falling_errors_slopes_tables_and_plots() {
    let dir = common::scratch("convergence");
    let args = ["bench", "convergence", "--budget", "2", "--reference-budget", "10", "--size", "16"];
    let strategies = ["--strategies", "pt-cosine,pt-mis,grid-pixel", "--out", dir.to_str().unwrap()];
    let o = Command::new(env!("CARGO_BIN_EXE_lucent")).args(args).args(strategies).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("rendered the reference"));

    let csv = std::fs::read_to_string(dir.join("convergence.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("strategy,seconds,spp,rays,rmse,relmse"));
    let mut waves: BTreeMap<String, Vec<(f64, u32, f64)>> = BTreeMap::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 6, "{line}");
        let rays: u64 = f[3].parse().unwrap();
        assert!(rays > 0);
        waves.entry(f[0].into()).or_default().push((
            f[1].parse().unwrap(),
            f[2].parse().unwrap(),
            f[4].parse().unwrap(),
        ));
    }
    assert_eq!(waves.len(), 3);
    for (name, w) in &waves {
        assert!(w.len() >= 6, "{name}: only {} waves", w.len());
        assert!(w.windows(2).all(|p| p[1].0 >= p[0].0 && p[1].1 > p[0].1), "{name}: time and spp increase");
    }
    // Unbiased: the error falls, at a fitted rate near time^-1/2. The tolerance covers the
    // fit's own noise over a 2 s run (the study reported -0.46 to -0.55 at 3 to 20 s).
    for name in ["pt-cosine", "pt-mis"] {
        let w = &waves[name];
        assert!(w.last().unwrap().2 < 0.5 * w[1].2, "{name}: error did not fall: {w:?}");
        let k = slope(w);
        assert!((-0.8..=-0.25).contains(&k), "{name}: slope {k:.2}");
    }
    // The pixel grid repeats itself after 16 spp: its error stops at its bias, above
    // where the unbiased MIS estimate gets to.
    let grid = &waves["grid-pixel"];
    let floor = grid.last().unwrap().2;
    assert!(floor > 0.8 * grid[grid.len() / 2].2, "grid error kept falling: {grid:?}");
    assert!(floor > waves["pt-mis"].last().unwrap().2, "grid below MIS");

    let table = std::fs::read_to_string(dir.join("convergence.md")).unwrap();
    assert!(table.contains("| grid-pixel (biased) |") && table.contains("efficiency"), "{table}");
    let png = image::open(dir.join("convergence.png")).unwrap();
    assert_eq!((png.width(), png.height()), (900, 600));
    let svg = std::fs::read_to_string(dir.join("convergence.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("pt-mis"), "{}", &svg[..svg.len().min(200)]);
}
