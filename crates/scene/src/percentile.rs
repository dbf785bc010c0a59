//! The one percentile helper of the workspace (nearest rank), shared by the
//! crowd statistics (`sim`) and the frame-time chart (`plot`), which both
//! depend on this crate.

/// Percentile by nearest rank of already sorted values: the smallest value
/// with at least `q` (0..=1, clamped) of the values at or below it; `None`
/// when empty.
pub fn percentile_sorted(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let rank = (q.clamp(0.0, 1.0) * sorted.len() as f64).ceil() as usize;
    Some(sorted[rank.clamp(1, sorted.len()) - 1])
}

#[cfg(test)]
mod tests {
    use super::percentile_sorted;

    #[test]
    fn nearest_rank_matches_brute_force() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile_sorted(&v, 0.5), Some(50.0));
        assert_eq!(percentile_sorted(&v, 0.95), Some(95.0));
        assert_eq!(percentile_sorted(&v, 1.0), Some(100.0));
        assert_eq!(percentile_sorted(&v, 0.0), Some(1.0));
        assert_eq!(percentile_sorted(&[], 0.5), None);
        // Brute force: the smallest value with at least q·n values ≤ it.
        let w = [1.0, 2.0, 2.0, 7.0, 9.0];
        for k in 0..=20 {
            let q = k as f64 / 20.0;
            let want = w
                .iter()
                .copied()
                .find(|x| w.iter().filter(|y| *y <= x).count() as f64 >= q * w.len() as f64)
                .unwrap();
            assert_eq!(percentile_sorted(&w, q), Some(want), "q {q}");
        }
    }
}
