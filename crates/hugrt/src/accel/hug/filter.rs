//! Filtering objects by size (EG95 §2.1, SCG97 §7.1).
//!
//! An object's *length* is its bounding-box diagonal. A filter splits the lengths into levels;
//! level 0 holds the smallest objects and the last level the largest, which the world grid
//! stores.

/// How object lengths are split into levels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    /// EG95: `k` levels holding equal counts of objects (slices of the sorted lengths). Equal
    /// lengths on a slice boundary stay together, in the upper level.
    Levels(usize),
    /// SCG97 §7.1: objects shorter than `fraction` of the longest go to level 0, the rest to
    /// level 1.
    Two(f32),
}

/// The objects of one level and its average length `f̄ = (f_k + f_{k+1}) / 2`: EG95 defines it
/// as the middle of the level's interval of lengths, which here is the interval from the
/// level's shortest to its longest object (the filter's thresholds are not themselves
/// lengths of anything).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Level {
    /// Indices into the filtered lengths, ascending.
    pub objects: Vec<u32>,
    pub mean_length: f32,
}

impl Filter {
    /// Splits `lengths` into levels, smallest first. Empty levels are dropped, so the last
    /// level is never empty unless there are no objects at all.
    pub fn apply(&self, lengths: &[f32]) -> Vec<Level> {
        if lengths.is_empty() {
            return Vec::new();
        }
        let thresholds: Vec<f32> = match *self {
            Filter::Levels(k) => {
                // The slice boundaries are order statistics: selection finds each in linear
                // time, each within the part of the lengths the previous one left above it.
                let mut rest = lengths.to_vec();
                let n = rest.len();
                let mut taken = 0;
                let mut out = Vec::new();
                for i in 1..k.max(1) {
                    let rank = i * n / k - taken;
                    let (_, &mut f, _) = rest.select_nth_unstable_by(rank, f32::total_cmp);
                    out.push(f);
                    rest.drain(..rank);
                    taken += rank;
                }
                out
            }
            Filter::Two(fraction) => {
                let max = lengths.iter().cloned().fold(0.0, f32::max);
                vec![fraction * max]
            }
        };
        let mut levels = vec![Level::default(); thresholds.len() + 1];
        for (i, &l) in lengths.iter().enumerate() {
            let k = thresholds.partition_point(|&f| f <= l);
            levels[k].objects.push(i as u32);
        }
        levels.retain(|l| !l.objects.is_empty());
        for level in &mut levels {
            let (lo, hi) = level
                .objects
                .iter()
                .map(|&i| lengths[i as usize])
                .fold((f32::INFINITY, 0.0f32), |(a, b), l| (a.min(l), b.max(l)));
            level.mean_length = (lo + hi) * 0.5;
        }
        levels
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_count_levels() {
        let lengths: Vec<f32> = (0..9).map(|i| i as f32).collect();
        let levels = Filter::Levels(3).apply(&lengths);
        let objs: Vec<Vec<u32>> = levels.iter().map(|l| l.objects.clone()).collect();
        assert_eq!(objs, vec![vec![0, 1, 2], vec![3, 4, 5], vec![6, 7, 8]]);
        assert_eq!(levels[2].mean_length, 7.0);
        // Equal lengths stay together: all in one level, none empty.
        let same = Filter::Levels(3).apply(&[1.0; 10]);
        assert_eq!(same.len(), 1);
        assert_eq!(same[0].objects.len(), 10);
    }

    #[test]
    fn two_level_filter_by_fraction() {
        let levels = Filter::Two(0.05).apply(&[100.0, 1.0, 4.9, 5.0, 50.0]);
        assert_eq!(levels[0].objects, vec![1, 2]);
        assert_eq!(levels[1].objects, vec![0, 3, 4]);
        assert!(Filter::Two(0.05).apply(&[]).is_empty());
    }
}
