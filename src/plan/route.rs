//! The order an operator visits the planned poses: a short closed tour from home and back —
//! nearest neighbour, then 2-opt — measuring joystick travel as the rotation angle between
//! consecutive orientations.

use nalgebra::Rotation3;

use crate::math::so3::geodesic_angle;

/// The visiting order of `poses` (indices) from and back to home (the identity), and the total
/// travel in radians.
///
/// # Panics
/// Never: the tour always starts at home.
pub(crate) fn tour(poses: &[Rotation3<f64>]) -> (Vec<usize>, f64) {
    // Node 0 is home, node k + 1 is poses[k].
    let nodes: Vec<Rotation3<f64>> = std::iter::once(Rotation3::identity()).chain(poses.iter().copied()).collect();
    let n = nodes.len();
    let distance = |a: usize, b: usize| geodesic_angle(&nodes[a], &nodes[b]);
    let mut order = vec![0];
    let mut left: Vec<usize> = (1..n).collect();
    while !left.is_empty() {
        let last = *order.last().expect("starts at home");
        let (k, _) = left
            .iter()
            .enumerate()
            .min_by(|a, b| distance(last, *a.1).total_cmp(&distance(last, *b.1)))
            .expect("not empty");
        order.push(left.swap_remove(k));
    }
    order.push(0);
    // 2-opt: reverse a stretch while that shortens the closed tour.
    let mut improved = true;
    while improved {
        improved = false;
        for i in 1..order.len() - 2 {
            for j in i + 1..order.len() - 1 {
                let before = distance(order[i - 1], order[i]) + distance(order[j], order[j + 1]);
                let after = distance(order[i - 1], order[j]) + distance(order[i], order[j + 1]);
                if after < before - 1e-12 {
                    order[i..=j].reverse();
                    improved = true;
                }
            }
        }
    }
    let travel = order.windows(2).map(|w| distance(w[0], w[1])).sum();
    (order[1..order.len() - 1].iter().map(|k| k - 1).collect(), travel)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn the_tour_visits_every_pose_once_and_is_no_longer_than_any_order_tried() {
        let poses: Vec<Rotation3<f64>> = (0..9)
            .map(|k| crate::math::so3::exp(&(Vector3::new((k as f64 * 2.1).sin(), (k as f64 * 1.3).cos(), 0.2) * 0.4)))
            .collect();
        let (order, travel) = tour(&poses);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..9).collect::<Vec<_>>());
        let length = |order: &[usize]| {
            let mut stops = vec![Rotation3::identity()];
            stops.extend(order.iter().map(|&k| poses[k]));
            stops.push(Rotation3::identity());
            stops.windows(2).map(|w| geodesic_angle(&w[0], &w[1])).sum::<f64>()
        };
        assert!((length(&order) - travel).abs() < 1e-12);
        // No single 2-opt move or the identity order is shorter.
        assert!(travel <= length(&(0..9).collect::<Vec<_>>()) + 1e-12);
    }
}
