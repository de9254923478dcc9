//! Small least-squares solvers: a line, a ratio, normal equations.

use super::MIN_POINTS;

/// Least squares y = a + b·x; returns (a, b, r², rms).
pub fn line_fit(pts: &[(f64, f64)]) -> Option<(f64, f64, f64, f64)> {
    let n = pts.len() as f64;
    if pts.len() < MIN_POINTS {
        return None;
    }
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |s, p| (s.0 + p.0, s.1 + p.1));
    let (mx, my) = (sx / n, sy / n);
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for (x, y) in pts {
        sxx += (x - mx) * (x - mx);
        sxy += (x - mx) * (y - my);
        syy += (y - my) * (y - my);
    }
    if !(sxx > 0.0) {
        return None;
    }
    let b = sxy / sxx;
    let a = my - b * mx;
    let rss: f64 = pts.iter().map(|(x, y)| (y - a - b * x).powi(2)).sum();
    let r2 = if syy > 0.0 { 1.0 - rss / syy } else { 0.0 };
    Some((a, b, r2, (rss / n).sqrt()))
}

/// Least squares through the origin y = k·x; returns (k, rms).
pub fn ratio_fit(pts: &[(f64, f64)]) -> Option<(f64, f64)> {
    let (sxy, sxx) = pts
        .iter()
        .fold((0.0, 0.0), |s, (x, y)| (s.0 + x * y, s.1 + x * x));
    (pts.len() >= MIN_POINTS && sxx > 0.0).then(|| {
        let k = sxy / sxx;
        let rss: f64 = pts.iter().map(|(x, y)| (y - k * x).powi(2)).sum();
        (k, (rss / pts.len() as f64).sqrt())
    })
}

/// Solve the small normal equations A·θ = b by Gaussian elimination with
/// partial pivoting.
pub fn solve<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for c in 0..N {
        let p = (c..N).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if !(a[p][c].abs() > 1e-12) {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..N {
            let f = a[r][c] / a[c][c];
            for k in c..N {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0.0; N];
    for r in (0..N).rev() {
        let s: f64 = (r + 1..N).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_fit_recovers_a_line() {
        let pts: Vec<(f64, f64)> = (0..50).map(|i| (i as f64, 2.0 + 0.5 * i as f64)).collect();
        let (a, b, r2, rms) = line_fit(&pts).unwrap();
        assert!((a - 2.0).abs() < 1e-9 && (b - 0.5).abs() < 1e-12 && r2 > 0.999_999 && rms < 1e-9);
    }

    #[test]
    fn solve_small_systems() {
        let x = solve(
            [[2.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 4.0]],
            [3.0, 5.0, 5.0],
        )
        .unwrap();
        for (got, want) in x.iter().zip([1.0, 1.0, 1.0]) {
            assert!((got - want).abs() < 1e-12);
        }
        assert!(solve([[1.0, 2.0], [2.0, 4.0]], [1.0, 2.0]).is_none());
    }
}
