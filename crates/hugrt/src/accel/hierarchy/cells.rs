//! The cells' references, indexed for the occupied cells only.

/// Where each cell's references lie, kept for the occupied cells only: most cells of most
/// scenes are empty (90% on a mesh at 2 cells per triangle, more in finer grids), and four
/// bytes of offset for each would dominate a fine grid's memory. One bit per cell says whether
/// it is occupied; the occupied cells before each 64-cell word (`rank`) plus the bits below
/// the cell in its word give its place among the occupied ones (a rank query on a bit
/// vector). About 0.2 bytes per cell plus 4 per occupied cell, where plain offsets take 4 per
/// cell; the walk reads the bits, which stay in cache, and touches the rest only for occupied
/// cells.
pub(super) struct CellIndex {
    pub(super) occupied: Vec<u64>,
    pub(super) rank: Vec<u32>,
    /// Start of each occupied cell's references in cell order, then the end of the last.
    pub(super) starts: Vec<u32>,
    pub(super) cells: usize,
}

impl CellIndex {
    /// From `(cell, reference)` pairs sorted by cell (cells in the upper 32 bits).
    pub(super) fn from_sorted(pairs: &[u64], cells: usize) -> CellIndex {
        let mut index = CellIndex::empty(cells);
        index.extend_sorted(pairs, 0);
        index.finish(pairs.len())
    }

    /// No cell occupied yet, of `cells`: [`CellIndex::extend_sorted`] adds them.
    pub(super) fn empty(cells: usize) -> CellIndex {
        CellIndex {
            occupied: vec![0u64; cells.div_ceil(64)],
            rank: Vec::new(),
            starts: Vec::new(),
            cells,
        }
    }

    /// Adds the cells of `pairs`, sorted by cell and all past the cells added before, whose
    /// references start at `first` among all references.
    pub(super) fn extend_sorted(&mut self, pairs: &[u64], first: usize) {
        let mut last = u64::MAX;
        for (k, &p) in pairs.iter().enumerate() {
            let c = p >> 32;
            if c != last {
                self.starts.push((first + k) as u32);
                self.occupied[c as usize / 64] |= 1 << (c % 64);
                last = c;
            }
        }
    }

    /// Adds occupied cells `first + c` for every `(c, start)` of `cells` (in cell order, all
    /// past the cells added before), whose references begin at `start`.
    pub(super) fn extend_occupied(&mut self, first: usize, cells: &[(u32, u32)]) {
        for &(c, start) in cells {
            let c = first + c as usize;
            self.starts.push(start);
            self.occupied[c / 64] |= 1 << (c % 64);
        }
    }

    /// The index, once every cell is added; `references` is their total.
    pub(super) fn finish(mut self, references: usize) -> CellIndex {
        self.starts.push(references as u32);
        self.starts.shrink_to_fit();
        let mut before = 0u32;
        self.rank = self
            .occupied
            .iter()
            .map(|w| {
                let r = before;
                before += w.count_ones();
                r
            })
            .collect();
        self
    }

    /// The references of cell `i` (start and end) and its rank among the occupied cells, or
    /// `None` when it has none.
    #[inline(always)]
    pub(super) fn range(&self, i: usize) -> Option<(usize, usize, usize)> {
        let w = self.occupied[i / 64];
        let bit = 1u64 << (i % 64);
        if w & bit == 0 {
            return None;
        }
        let r = self.rank[i / 64] as usize + (w & (bit - 1)).count_ones() as usize;
        Some((self.starts[r] as usize, self.starts[r + 1] as usize, r))
    }

    pub(super) fn memory_bytes(&self) -> usize {
        8 * self.occupied.capacity() + 4 * (self.rank.capacity() + self.starts.capacity())
    }
}

/// Cells a block spans along each axis: [`BlockIndex`].
pub(super) const BLOCK: u32 = 4;

/// Which blocks of `BLOCK`³ cells of each grid hold an occupied cell: one bit a block, a
/// 64th of a bit a cell. A packet crosses the empty blocks of a fine grid a block of slices
/// at a time rather than slice by slice ([`super::packet`]): EG95's uniform cells are finest
/// where the objects are, and a camera's packets cross mostly empty space to reach them.
pub(super) struct BlockIndex {
    bits: Vec<u64>,
    /// Each grid's first block among all grids' blocks, and its blocks per axis.
    grids: Vec<(usize, [u32; 3])>,
}

impl BlockIndex {
    /// The blocks of `grids`, whose occupied cells `cells` lists.
    pub(super) fn new(grids: &[super::header::GridHeader], cells: &CellIndex) -> BlockIndex {
        let mut first = 0usize;
        let layout: Vec<(usize, [u32; 3])> = grids
            .iter()
            .map(|h| {
                let res = h.res.map(|r| r.div_ceil(BLOCK));
                let me = first;
                first += res.iter().map(|&r| r as usize).product::<usize>();
                (me, res)
            })
            .collect();
        let mut bits = vec![0u64; first.div_ceil(64)];
        for (h, &(start, res)) in grids.iter().zip(&layout) {
            let (c0, n) = (h.first_cell as usize, h.cells());
            let (rx, ry) = (h.res[0] as usize, h.res[1] as usize);
            let mut i = c0;
            while i < c0 + n {
                let w = cells.occupied[i / 64] >> (i % 64);
                if w == 0 {
                    i = (i / 64 + 1) * 64;
                    continue;
                }
                i += w.trailing_zeros() as usize;
                if i >= c0 + n {
                    break;
                }
                let local = i - c0;
                let (x, y, z) = (local % rx, local / rx % ry, local / (rx * ry));
                let b = start
                    + x / BLOCK as usize
                    + (y / BLOCK as usize) * res[0] as usize
                    + (z / BLOCK as usize) * res[0] as usize * res[1] as usize;
                bits[b / 64] |= 1 << (b % 64);
                i += 1;
            }
        }
        BlockIndex {
            bits,
            grids: layout,
        }
    }

    /// Whether any block of grid `g` with block coordinates `lo[a]..=hi[a]` on every axis `a`
    /// holds an occupied cell.
    #[inline]
    pub(super) fn any(&self, g: usize, lo: [u32; 3], hi: [u32; 3]) -> bool {
        let (start, res) = self.grids[g];
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let row = start + (z as usize * res[1] as usize + y as usize) * res[0] as usize;
                for x in lo[0]..=hi[0] {
                    let b = row + x as usize;
                    if self.bits[b / 64] >> (b % 64) & 1 != 0 {
                        return true;
                    }
                }
            }
        }
        false
    }

    pub(super) fn memory_bytes(&self) -> usize {
        8 * self.bits.capacity() + std::mem::size_of::<(usize, [u32; 3])>() * self.grids.capacity()
    }
}
