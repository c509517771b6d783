//! Many points summarised for a chart. An hour-long recording has some 50,000 poses: drawn one
//! dot each they make a solid blob (and megabytes of SVG) that shows neither the typical error
//! nor its spread. Along a line (error against time) they become bins with their median and
//! 5–95 % band; over a plane (the workspace) a grid of cells with their counts.

/// One bin of a series: its index along x, its centre, and the 5 %, 50 % and 95 % quantiles of the
/// values that fell in it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bin {
    /// Index of the bin from the start of the span (empty bins have none: a gap shows).
    pub(crate) index: usize,
    /// Centre of the bin along x.
    pub(crate) x: f64,
    /// 5 % quantile.
    pub(crate) low: f64,
    /// Median.
    pub(crate) median: f64,
    /// 95 % quantile.
    pub(crate) high: f64,
}

/// `points` in `bins` equal bins of x over `[x0, x1]` (a point at `x1` falls in the last), each
/// non-empty bin with its quantiles; points outside the span are left out.
pub(crate) fn binned(points: &[(f64, f64)], (x0, x1): (f64, f64), bins: usize) -> Vec<Bin> {
    let bins = bins.max(1);
    let width = (x1 - x0) / bins as f64;
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); bins];
    for &(x, y) in points {
        if !(x0..=x1).contains(&x) || !y.is_finite() {
            continue;
        }
        let k = if width > 0.0 { (((x - x0) / width) as usize).min(bins - 1) } else { 0 };
        values[k].push(y);
    }
    values
        .into_iter()
        .enumerate()
        .filter(|(_, v)| !v.is_empty())
        .map(|(index, mut v)| {
            v.sort_by(f64::total_cmp);
            Bin {
                index,
                x: x0 + width * (index as f64 + 0.5),
                low: quantile(&v, 0.05),
                median: quantile(&v, 0.5),
                high: quantile(&v, 0.95),
            }
        })
        .collect()
}

/// Runs of adjacent bins: a band is drawn over each run, so that a stretch without data is a gap
/// and not a straight line across it.
pub(crate) fn runs(bins: &[Bin]) -> Vec<&[Bin]> {
    let mut out = Vec::new();
    let mut start = 0;
    for k in 1..=bins.len() {
        if k == bins.len() || bins[k].index != bins[k - 1].index + 1 {
            out.push(&bins[start..k]);
            start = k;
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

/// The `q`-quantile of sorted values, interpolated linearly between order statistics (the
/// definition of R's default and numpy's `linear`): `sorted[(n − 1) q]`.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let at = (sorted.len() - 1) as f64 * q;
    let (below, frac) = (at.floor() as usize, at.fract());
    match sorted.get(below + 1) {
        Some(next) => sorted[below] + frac * (next - sorted[below]),
        None => sorted[below],
    }
}

/// How many points fall in each cell of a `cells × cells` grid over `[−reach, reach]²`, as
/// `(column, row, count)` for the non-empty cells (column along x, row along y, from −reach).
pub(crate) fn density(points: &[(f64, f64)], reach: f64, cells: usize) -> Vec<(usize, usize, usize)> {
    let cells = cells.max(1);
    let mut counts = vec![0usize; cells * cells];
    let cell = |v: f64| (((v + reach) / (2.0 * reach) * cells as f64).floor().max(0.0) as usize).min(cells - 1);
    for &(x, y) in points.iter().filter(|(x, y)| x.abs() <= reach && y.abs() <= reach) {
        counts[cell(y) * cells + cell(x)] += 1;
    }
    counts.into_iter().enumerate().filter(|(_, n)| *n > 0).map(|(k, n)| (k % cells, k / cells, n)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_bin_holds_its_quantiles() {
        // Bin 0 holds 0, 1, …, 100 (quantiles by hand: 5, 50, 95); bin 1 nothing; bin 2 one value.
        let mut points: Vec<(f64, f64)> = (0..=100).map(|k| (0.5, k as f64)).collect();
        points.push((2.9, 7.0));
        points.push((3.5, 1e9)); // outside the span
        let bins = binned(&points, (0.0, 3.0), 3);
        assert_eq!(bins.len(), 2);
        assert_eq!((bins[0].index, bins[0].x, bins[0].low, bins[0].median, bins[0].high), (0, 0.5, 5.0, 50.0, 95.0));
        assert_eq!((bins[1].index, bins[1].x, bins[1].low, bins[1].median, bins[1].high), (2, 2.5, 7.0, 7.0, 7.0));
        // Two runs: the empty bin is a gap.
        assert_eq!(runs(&bins).iter().map(|r| r.len()).collect::<Vec<_>>(), [1, 1]);
    }

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        // numpy.quantile([1, 2, 3, 4], [0.05, 0.5, 0.95]) = [1.15, 2.5, 3.85].
        let v = [1.0, 2.0, 3.0, 4.0];
        for (q, expected) in [(0.05, 1.15), (0.5, 2.5), (0.95, 3.85)] {
            assert!((quantile(&v, q) - expected).abs() < 1e-12, "{q}");
        }
    }

    #[test]
    fn the_grid_counts_every_point_inside_once() {
        let points = [(-1.0, -1.0), (-0.99, -0.99), (0.99, -0.99), (1.0, 1.0), (0.0, 0.0), (2.0, 0.0)];
        let mut cells = density(&points, 1.0, 2);
        cells.sort();
        // (2, 0) is outside; (0, 0) and (1, 1) fall in the upper right cell.
        assert_eq!(cells, [(0, 0, 2), (1, 0, 1), (1, 1, 2)]);
    }
}
