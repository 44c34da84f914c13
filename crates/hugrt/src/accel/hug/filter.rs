//! Filtering objects by size (EG95 §2.1, SCG97 §7.1).
//!
//! An object's *length* is its bounding-box diagonal. A filter splits the lengths into levels;
//! level 0 holds the smallest objects and the last level the largest, which the world grid
//! stores.

use rayon::prelude::*;

/// How object lengths are split into levels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    /// EG95: `k` levels holding equal counts of objects (slices of the sorted lengths). Equal
    /// lengths on a slice boundary stay together, in the upper level.
    Levels(usize),
    /// SCG97 §7.1: objects shorter than `fraction` of the longest go to level 0, the rest to
    /// level 1.
    Two(f32),
    /// hugrt's: [`Filter::Two`], with the split moved up into the widest empty octave of the
    /// lengths within three octaves above it, where `fraction` falls among many lengths (not
    /// already in an empty octave of its own). SCG97 §7.1 asks a two-level filter to
    /// "keep apart the big objects that would bridge the gaps from the small ones" and takes
    /// 5% of the biggest as a rule of thumb; where that cuts through a crowd of lengths with an
    /// empty octave nearby, the empty octave keeps them apart better.
    Gap(f32),
}

/// Lengths a task of the filter's passes takes.
const CHUNK: usize = 1 << 14;

/// Octaves each side of the fraction's split over which [`gap_split`] looks for a gap.
const GAP_WINDOW: u32 = 3;

/// Bins per octave of [`gap_split`]'s histogram: a float's exponent and its mantissa's top
/// three bits, so bins of an eighth of an octave in count, an eighth to a sixteenth in size.
const GAP_BINS: u32 = 8;

/// Empty bins in a row that make a gap: about an octave with no object's length.
const GAP_MIN: usize = GAP_BINS as usize;

/// Bins of [`LengthCensus`]'s histogram: every value of a non-negative float's bits from bit
/// 20 up (its exponent and three mantissa bits), infinity included.
const CENSUS_BINS: usize = 1 << 11;

/// What the size filters need to know of the lengths, gathered as they are measured: how
/// many, the shortest and the longest, and a histogram of their bits from bit 20 up (a
/// positive float's bits grow with it), [`Filter::Gap`]'s. From it alone a filter of two
/// levels finds its split and whether every object falls on one side of it: on a mesh of
/// one size class (the big SPD terrain's 524,288 triangles) the HUG's planning then makes no
/// list of lengths and no second pass over them.
#[derive(Clone, Debug, PartialEq)]
pub struct LengthCensus {
    pub count: usize,
    /// The shortest length (infinity when there are none).
    pub shortest: f32,
    /// The longest length (0 when there are none).
    pub longest: f32,
    bins: Vec<u32>,
}

impl Default for LengthCensus {
    fn default() -> Self {
        LengthCensus {
            count: 0,
            shortest: f32::INFINITY,
            longest: 0.0,
            bins: vec![0; CENSUS_BINS],
        }
    }
}

impl LengthCensus {
    /// Counts length `l`, a non-negative number (a box's diagonal).
    #[inline]
    pub fn add(&mut self, l: f32) {
        self.count += 1;
        self.shortest = self.shortest.min(l);
        self.longest = self.longest.max(l);
        self.bins[((l.to_bits() >> 20) as usize).min(CENSUS_BINS - 1)] += 1;
    }

    /// The census of both sets of lengths.
    pub fn merge(mut self, other: &LengthCensus) -> LengthCensus {
        self.count += other.count;
        self.shortest = self.shortest.min(other.shortest);
        self.longest = self.longest.max(other.longest);
        self.bins
            .iter_mut()
            .zip(&other.bins)
            .for_each(|(a, b)| *a += b);
        self
    }

    /// The census of `lengths`, in parallel.
    pub fn of(lengths: &[f32]) -> LengthCensus {
        lengths
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut census = LengthCensus::default();
                chunk.iter().for_each(|&l| census.add(l));
                census
            })
            .reduce(LengthCensus::default, |a, b| a.merge(&b))
    }
}

/// Where [`Filter::Gap`] splits lengths for a split at `t` (`fraction` of the longest): `t`
/// itself where it lies in a gap (at least [`GAP_MIN`] empty bins of the lengths' histogram
/// in a row) or where no gap lies within [`GAP_WINDOW`] octaves above it; else the middle of
/// the widest such gap (the nearest of equals). Every split inside a gap makes the same two
/// levels. The histogram is the census's, read without a logarithm: bits 20 and up of a
/// positive float are its exponent and three mantissa bits.
///
/// On SPD gears (36,608 small polygons up to a tenth of the two longest, which are 170 times
/// the shortest) 5% cuts the small ones in two, and the larger part fills the world grid;
/// the gap above them leaves the world only the two long ones (512² Whitted 1.31-1.34×
/// faster, balls 1.09-1.11×: `docs/measurements.md`). The split is moved up only: moved down
/// into a gap below it, more objects went to the world grid on the generated scenes, whose
/// builds grew (the stadium's twice as long) for little or no gain in their trace.
fn gap_split(census: &LengthCensus, t: f32) -> f32 {
    let lo = t / (1u32 << GAP_WINDOW) as f32;
    if !lo.is_normal() || !(t * (1u32 << GAP_WINDOW) as f32).is_finite() {
        return t;
    }
    const BINS: usize = (2 * GAP_WINDOW * GAP_BINS) as usize;
    let base = (lo.to_bits() >> 20) as usize;
    // A normal `lo` with `8·t` finite: the window's bins lie below infinity's.
    let count = &census.bins[base..base + BINS];
    // The empty runs: (first bin, length).
    let mut runs = Vec::new();
    let mut k = 0;
    while k < BINS {
        if count[k] == 0 {
            let start = k;
            while k < BINS && count[k] == 0 {
                k += 1;
            }
            runs.push((start, k - start));
        } else {
            k += 1;
        }
    }
    let at = BINS / 2;
    if runs
        .iter()
        .any(|&(s, n)| (s..s + n).contains(&at) && n >= GAP_MIN)
    {
        return t;
    }
    match runs
        .iter()
        .filter(|&&(s, n)| s > at && n >= GAP_MIN)
        .max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
    {
        Some(&(s, n)) => f32::from_bits(((base + s + n / 2) as u32) << 20),
        None => t,
    }
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
    /// The lengths at which the filter splits levels, from the lengths' census alone; `None`
    /// for [`Filter::Levels`], whose splits are order statistics of the lengths themselves.
    pub fn thresholds(&self, census: &LengthCensus) -> Option<Vec<f32>> {
        // SCG97's split: `fraction` of the longest length.
        let split = |fraction: f32| fraction * census.longest;
        match *self {
            Filter::Levels(_) => None,
            Filter::Two(fraction) => Some(vec![split(fraction)]),
            Filter::Gap(fraction) => Some(vec![gap_split(census, split(fraction))]),
        }
    }

    /// The mean length of the one level every length falls in, if the census shows that they
    /// all do: [`Filter::apply`] then makes one level of every object with this mean, which
    /// is found without the lengths themselves.
    pub fn one_level_mean(&self, census: &LengthCensus) -> Option<f32> {
        let thresholds = self.thresholds(census)?;
        let level_of = |l: f32| thresholds.partition_point(|&f| f <= l);
        (census.count > 0 && level_of(census.shortest) == level_of(census.longest))
            .then_some((census.shortest + census.longest) * 0.5)
    }

    /// Splits `lengths` into levels, smallest first. Empty levels are dropped, so the last
    /// level is never empty unless there are no objects at all.
    pub fn apply(&self, lengths: &[f32]) -> Vec<Level> {
        self.apply_counted(&LengthCensus::of(lengths), lengths)
    }

    /// [`Filter::apply`] with the lengths' census already taken: `census` is
    /// [`LengthCensus::of`] `lengths`.
    pub fn apply_counted(&self, census: &LengthCensus, lengths: &[f32]) -> Vec<Level> {
        if lengths.is_empty() {
            return Vec::new();
        }
        let thresholds: Vec<f32> = match self.thresholds(census) {
            Some(thresholds) => thresholds,
            None => {
                // The slice boundaries are order statistics: selection finds each in linear
                // time, each within the part of the lengths the previous one left above it.
                let k = match *self {
                    Filter::Levels(k) => k,
                    _ => unreachable!("only Levels has no thresholds from the census"),
                };
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
        };
        let level_of = |l: f32| thresholds.partition_point(|&f| f <= l);
        // Each level's count and its shortest and longest lengths first, so that each list
        // is made at its size: grown by pushes, copied at every doubling, the lists took a
        // fifth of the filter's time on the big SPD terrain's 524,288 triangles.
        let empty = vec![(0usize, f32::INFINITY, 0.0f32); thresholds.len() + 1];
        let census = lengths
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut census = empty.clone();
                for &l in chunk {
                    let (count, lo, hi) = &mut census[level_of(l)];
                    (*count, *lo, *hi) = (*count + 1, lo.min(l), hi.max(l));
                }
                census
            })
            .reduce(
                || empty.clone(),
                |a, b| {
                    a.iter()
                        .zip(&b)
                        .map(|(&(n, lo, hi), &(m, lo2, hi2))| (n + m, lo.min(lo2), hi.max(hi2)))
                        .collect()
                },
            );
        census
            .iter()
            .enumerate()
            .filter(|(_, c)| c.0 > 0)
            .map(|(level, &(count, lo, hi))| {
                // In index order: an indexed parallel collect keeps it.
                let objects: Vec<u32> = if count == lengths.len() {
                    (0..count as u32).into_par_iter().collect()
                } else {
                    (0..lengths.len() as u32)
                        .into_par_iter()
                        .filter(|&i| level_of(lengths[i as usize]) == level)
                        .collect()
                };
                Level {
                    objects,
                    mean_length: (lo + hi) * 0.5,
                }
            })
            .collect()
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

    /// The lower level's objects of `filter` on `lengths`.
    fn lower(filter: Filter, lengths: &[f32]) -> Vec<u32> {
        let levels = filter.apply(lengths);
        if levels.len() < 2 {
            return Vec::new();
        }
        levels[0].objects.clone()
    }

    #[test]
    fn the_gap_filter_moves_a_split_out_of_a_crowd_into_an_empty_octave() {
        // Gears' shape: many lengths from 0.6 to 9.9 (the split at 5% of 100, 5.0, among
        // them), an empty run up to the two longest.
        let mut crowd: Vec<f32> = (0..1000).map(|i| 0.6 + 9.3 * i as f32 / 999.0).collect();
        crowd.extend([98.0, 100.0]);
        let split = lower(Filter::Two(0.05), &crowd).len();
        assert!(split > 100 && split < 900, "5% cuts the crowd: {split}");
        assert_eq!(
            lower(Filter::Gap(0.05), &crowd),
            (0..1000).collect::<Vec<u32>>()
        );
        // A gap below the split only: the split stays (moved up only).
        let mut low: Vec<f32> = (0..100).map(|i| 0.65 + 0.05 * i as f32 / 99.0).collect();
        low.extend((0..1000).map(|i| 2.0 + 28.0 * i as f32 / 999.0));
        low.push(100.0);
        assert_eq!(
            lower(Filter::Gap(0.05), &low),
            lower(Filter::Two(0.05), &low)
        );
        assert!(lower(Filter::Gap(0.05), &low).len() > 100);
        // The split already in a gap stays: the same levels as SCG97's.
        let apart = [100.0, 1.0, 1.5, 2.0, 20.0, 30.0, 50.0];
        assert_eq!(
            lower(Filter::Gap(0.05), &apart),
            lower(Filter::Two(0.05), &apart)
        );
        assert_eq!(lower(Filter::Gap(0.05), &apart), vec![1, 2, 3]);
        // No gap near the split: SCG97's split, where it cuts.
        let even: Vec<f32> = (1..=1000).map(|i| i as f32 / 10.0).collect();
        assert_eq!(
            lower(Filter::Gap(0.05), &even),
            lower(Filter::Two(0.05), &even)
        );
        assert_eq!(lower(Filter::Gap(0.05), &even).len(), 49);
        // Degenerate lengths: all zero, one object.
        assert_eq!(Filter::Gap(0.05).apply(&[0.0; 4]).len(), 1);
        assert_eq!(Filter::Gap(0.05).apply(&[3.0]).len(), 1);
    }

    /// The census's answer, where it gives one, is the filter's on the lengths themselves.
    #[test]
    fn one_level_from_the_census_is_what_apply_finds() {
        let mesh: Vec<f32> = (0..5000).map(|i| 0.5 + (i % 97) as f32 / 194.0).collect();
        let mut gears: Vec<f32> = (0..1000).map(|i| 0.6 + 9.3 * i as f32 / 999.0).collect();
        gears.extend([98.0, 100.0]);
        let even: Vec<f32> = (1..=1000).map(|i| i as f32 / 10.0).collect();
        let cases = [
            mesh,
            gears,
            even,
            vec![1.0; 10],
            vec![3.0],
            vec![0.0; 4],
            vec![],
        ];
        let mut found = 0;
        for filter in [Filter::Two(0.05), Filter::Gap(0.05), Filter::Levels(3)] {
            for lengths in &cases {
                let levels = filter.apply(lengths);
                match filter.one_level_mean(&LengthCensus::of(lengths)) {
                    Some(mean) => {
                        found += 1;
                        assert_eq!(levels.len(), 1, "{filter:?} on {} lengths", lengths.len());
                        assert_eq!(levels[0].mean_length, mean);
                        assert_eq!(levels[0].objects.len(), lengths.len());
                    }
                    None => assert!(
                        levels.len() != 1 || matches!(filter, Filter::Levels(_)),
                        "{filter:?} on {} lengths: one level the census missed",
                        lengths.len()
                    ),
                }
            }
        }
        // The mesh, the equal lengths, the single one and the zeros, for both splits.
        assert_eq!(found, 8);
    }
}
