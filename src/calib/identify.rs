//! Identifiability: the SVD of the column-scaled identification Jacobian `W^½ J D⁻¹`
//! (`D` = column norms, so that units and leverage do not hide or fake a weak direction).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// A direction of parameter space, named by its largest components.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Direction {
    /// Its scaled singular value over the largest one.
    pub singular_ratio: f64,
    /// `(parameter, component)` of the unit direction (unscaled), largest first, at most 4.
    pub components: Vec<(String, f64)>,
}

impl Direction {
    /// One line for messages: the largest components and the singular-value ratio.
    pub fn describe(&self) -> String {
        let parts: Vec<String> = self.components.iter().map(|(n, c)| format!("{c:+.2}·{n}")).collect();
        format!("{} (σ/σmax = {:.1e})", parts.join(" "), self.singular_ratio)
    }
}

/// The analysis of one Jacobian.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Identifiability {
    /// Free parameters.
    pub parameters: usize,
    /// Directions above the threshold.
    pub rank: usize,
    /// Largest over smallest scaled singular value.
    pub condition: f64,
    /// The three weakest directions.
    pub weakest: Vec<Direction>,
    /// Every scaled singular value over the largest, largest first (the spectrum).
    pub spectrum: Vec<f64>,
    /// Directions below the threshold.
    pub unidentifiable: Vec<Direction>,
    /// Those directions as unit vectors in the full parameter space (unscaled), for regularising.
    #[serde(skip)]
    pub null_vectors: Vec<DVector<f64>>,
    /// Largest scaled singular value squared (the scale for a prior).
    #[serde(skip)]
    pub scale: f64,
    /// Column norms `D` of the free parameters, in the full space (1 for frozen ones).
    #[serde(skip)]
    pub column_norms: DVector<f64>,
}

/// [`Identifiability::analyse`] from the Gram matrix `JᵀWJ` (N × N) of the weighted Jacobian: the singular values
/// and right vectors of the column-scaled Jacobian are the roots and vectors of the scaled Gram
/// matrix's eigen-decomposition. At 100,000 observations an SVD of the tall matrix cost a second.
/// Squaring the spectrum puts a null direction at ~1e-8 of the largest singular value instead of
/// ~1e-16, still far below any `min_singular_ratio` worth using (1e-6 by default).
pub(crate) fn analyse_gram(
    gram_all: &DMatrix<f64>,
    free: &[usize],
    names: &[String],
    min_ratio: f64,
) -> Identifiability {
    let n_all = gram_all.ncols();
    let mut column_norms = DVector::from_element(n_all, 1.0);
    for &i in free {
        let norm = gram_all[(i, i)].max(0.0).sqrt();
        column_norms[i] = if norm > 0.0 { norm } else { 1.0 };
    }
    if free.is_empty() {
        // Nothing free: no direction to analyse.
        return Identifiability::nothing(free.len(), column_norms);
    }
    let gram = DMatrix::from_fn(free.len(), free.len(), |a, b| {
        gram_all[(free[a], free[b])] / (column_norms[free[a]] * column_norms[free[b]])
    });
    // Non-finite Jacobians never reach here (the fit stops on a non-finite cost); bounded all the same.
    let Some(eigen) = crate::math::linalg::bounded_symmetric_eigen(&gram) else {
        return Identifiability::nothing(free.len(), column_norms);
    };
    let v_t = eigen.eigenvectors.transpose();
    let s = eigen.eigenvalues.map(|l| l.max(0.0).sqrt());
    let s = &s;
    let s_max = s.max().max(f64::MIN_POSITIVE);
    let mut order: Vec<usize> = (0..s.len()).collect();
    order.sort_by(|&a, &b| s[a].total_cmp(&s[b]));
    let direction = |idx: usize| -> (Direction, DVector<f64>) {
        let mut full = DVector::zeros(n_all);
        for (k, &i) in free.iter().enumerate() {
            full[i] = v_t[(idx, k)] / column_norms[i];
        }
        let full = full.normalize();
        let mut comps: Vec<(String, f64)> = free.iter().map(|&i| (names[i].clone(), full[i])).collect();
        comps.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        comps.truncate(4);
        comps.retain(|(_, c)| c.abs() > 0.05);
        (Direction { singular_ratio: s[idx] / s_max, components: comps }, full)
    };
    let weak: Vec<usize> = order.iter().copied().filter(|&i| s[i] < min_ratio * s_max).collect();
    let (unidentifiable, null_vectors) = weak.iter().map(|&i| direction(i)).unzip();
    Identifiability {
        parameters: free.len(),
        rank: free.len() - weak.len(),
        condition: s_max / s.min().max(f64::MIN_POSITIVE),
        weakest: order.iter().take(3).map(|&i| direction(i).0).collect(),
        spectrum: order.iter().rev().map(|&i| s[i] / s_max).collect(),
        unidentifiable,
        null_vectors,
        scale: s_max * s_max,
        column_norms,
    }
}

impl Identifiability {
    /// Analyse `W^½ J` (3n × N) over the `free` parameters.
    ///
    /// # Panics
    /// If `free` or `names` index past the Jacobian's columns.
    pub fn analyse(weighted_jacobian: &DMatrix<f64>, free: &[usize], names: &[String], min_ratio: f64) -> Self {
        if weighted_jacobian.nrows() == 0 {
            // No data: no direction to analyse.
            return Self::nothing(free.len(), DVector::from_element(weighted_jacobian.ncols(), 1.0));
        }
        analyse_gram(&crate::math::linalg::gram(weighted_jacobian), free, names, min_ratio)
    }

    /// The analysis of nothing (no free parameter, no data, or a Jacobian that cannot be decomposed).
    fn nothing(parameters: usize, column_norms: DVector<f64>) -> Self {
        Identifiability {
            parameters,
            rank: 0,
            condition: f64::INFINITY,
            weakest: Vec::new(),
            spectrum: Vec::new(),
            unidentifiable: Vec::new(),
            null_vectors: Vec::new(),
            scale: 0.0,
            column_norms,
        }
    }

    /// A weak prior `Λ` that pins the unidentifiable directions: strong against their (near-zero)
    /// information, negligible against any identified direction's.
    pub fn prior(&self, n: usize) -> Option<DMatrix<f64>> {
        if self.null_vectors.is_empty() {
            return None;
        }
        let mut lambda = DMatrix::zeros(n, n);
        for v in &self.null_vectors {
            // In scaled coordinates x̃ = D x the prior is 1e-4 σ_max² (ṽᵀ x̃)²; ṽ = D v / |D v|.
            let dv = v.component_mul(&self.column_norms);
            let dv = &dv / dv.norm();
            let row = dv.component_mul(&self.column_norms);
            lambda += &row * row.transpose() * (1e-4 * self.scale);
        }
        Some(lambda)
    }
}
