//! Tiles of the paint layers and the undo history built from them: an edit snapshots each
//! tile just before it first touches it; undoing swaps the snapshots back in (which leaves
//! the undone state in the step, ready for redo), so both directions are exact.

use super::changes::PixelRect;
use super::layers::PaintLayers;
use std::collections::VecDeque;

/// Tile side in pixels: 64² pixels of colour and coverage are 64 KiB, so a dab touches few
/// and a snapshot is one short copy.
pub(crate) const TILE: usize = 64;

/// How a `width` × `height` canvas is cut into tiles, row-major from the top left; tiles on
/// the right and bottom edges may be smaller.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TileGrid {
    width: usize,
    height: usize,
    columns: usize,
    rows: usize,
}

impl TileGrid {
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            columns: width.div_ceil(TILE),
            rows: height.div_ceil(TILE),
        }
    }

    pub fn count(&self) -> usize {
        self.columns * self.rows
    }

    pub fn width(&self) -> usize {
        self.width
    }

    /// The pixels of tile `tile`.
    pub fn rect(&self, tile: usize) -> PixelRect {
        let (tx, ty) = (tile % self.columns, tile / self.columns);
        let (x0, y0) = (tx * TILE, ty * TILE);
        PixelRect::new(
            x0 as u32,
            y0 as u32,
            (x0 + TILE).min(self.width) as u32,
            (y0 + TILE).min(self.height) as u32,
        )
    }

    /// The tiles that meet `rect` (which must lie inside the canvas).
    pub fn tiles_in(&self, rect: PixelRect) -> impl Iterator<Item = usize> + use<> {
        let columns = self.columns;
        let (tx0, tx1, ty0, ty1) = if rect.is_empty() {
            (0, 0, 0, 0)
        } else {
            (
                rect.x0 as usize / TILE,
                (rect.x1 as usize).div_ceil(TILE),
                rect.y0 as usize / TILE,
                (rect.y1 as usize).div_ceil(TILE),
            )
        };
        (ty0..ty1).flat_map(move |ty| (tx0..tx1).map(move |tx| ty * columns + tx))
    }
}

/// Colour and coverage of one tile, row-major within the tile.
#[derive(Clone, Debug)]
pub(crate) struct TileData {
    pub tile: usize,
    pub colour: Vec<[f32; 3]>,
    pub coverage: Vec<f32>,
}

impl TileData {
    pub fn capture(layers: &PaintLayers, grid: &TileGrid, tile: usize) -> Self {
        let rect = grid.rect(tile);
        let n = (rect.width() * rect.height()) as usize;
        let mut colour = Vec::with_capacity(n);
        let mut coverage = Vec::with_capacity(n);
        for row in rows(grid, rect) {
            colour.extend_from_slice(&layers.colour.pixels[row.clone()]);
            coverage.extend_from_slice(&layers.coverage[row]);
        }
        Self {
            tile,
            colour,
            coverage,
        }
    }

    /// Exchanges this snapshot with the tile's pixels in `layers`.
    pub fn swap_with(&mut self, layers: &mut PaintLayers, grid: &TileGrid) {
        let rect = grid.rect(self.tile);
        let w = rect.width() as usize;
        for (i, row) in rows(grid, rect).enumerate() {
            let local = i * w..(i + 1) * w;
            layers.colour.pixels[row.clone()].swap_with_slice(&mut self.colour[local.clone()]);
            layers.coverage[row].swap_with_slice(&mut self.coverage[local]);
        }
    }

    /// Whether `layers` still hold exactly (bit for bit) this snapshot.
    pub fn same_as(&self, layers: &PaintLayers, grid: &TileGrid) -> bool {
        let rect = grid.rect(self.tile);
        let w = rect.width() as usize;
        rows(grid, rect).enumerate().all(|(i, row)| {
            let local = i * w..(i + 1) * w;
            let colours = layers.colour.pixels[row.clone()]
                .iter()
                .zip(&self.colour[local.clone()])
                .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits));
            colours
                && layers.coverage[row]
                    .iter()
                    .zip(&self.coverage[local])
                    .all(|(a, b)| a.to_bits() == b.to_bits())
        })
    }

    pub fn bytes(&self) -> usize {
        self.colour.len() * size_of::<[f32; 3]>() + self.coverage.len() * size_of::<f32>()
    }
}

/// The canvas index ranges of each row of `rect`.
fn rows(grid: &TileGrid, rect: PixelRect) -> impl Iterator<Item = std::ops::Range<usize>> {
    let width = grid.width();
    (rect.y0 as usize..rect.y1 as usize)
        .map(move |y| y * width + rect.x0 as usize..y * width + rect.x1 as usize)
}

/// One undoable edit: the tiles it changed, holding their state from before the edit (while
/// on the undo stack) or after it (while on the redo stack).
#[derive(Clone, Debug)]
pub(crate) struct Step {
    pub tiles: Vec<TileData>,
}

impl Step {
    fn bytes(&self) -> usize {
        self.tiles.iter().map(TileData::bytes).sum()
    }
}

/// Undo and redo stacks under a memory budget shared by both.
#[derive(Clone, Debug)]
pub(crate) struct History {
    undo: VecDeque<Step>,
    redo: Vec<Step>,
    bytes: usize,
    budget: usize,
}

impl History {
    pub fn new(budget: usize) -> Self {
        Self {
            undo: VecDeque::new(),
            redo: Vec::new(),
            bytes: 0,
            budget,
        }
    }

    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    pub fn bytes(&self) -> usize {
        self.bytes
    }

    pub fn undo_len(&self) -> usize {
        self.undo.len()
    }

    pub fn clear_redo(&mut self) {
        for step in self.redo.drain(..) {
            self.bytes -= step.bytes();
        }
    }

    /// Records a finished edit, then drops the oldest steps until the budget holds.
    pub fn push(&mut self, step: Step) {
        self.bytes += step.bytes();
        self.undo.push_back(step);
        self.enforce_budget();
    }

    pub fn set_budget(&mut self, bytes: usize) {
        self.budget = bytes;
        self.enforce_budget();
    }

    /// Oldest undo steps go first; only if they are all gone do redo steps go, farthest first.
    fn enforce_budget(&mut self) {
        while self.bytes > self.budget {
            let dropped = match self.undo.pop_front() {
                Some(step) => step,
                None if !self.redo.is_empty() => self.redo.remove(0),
                None => break,
            };
            self.bytes -= dropped.bytes();
        }
    }

    pub fn pop_undo(&mut self) -> Option<Step> {
        self.undo.pop_back()
    }

    pub fn push_redo(&mut self, step: Step) {
        self.redo.push(step);
    }

    pub fn pop_redo(&mut self) -> Option<Step> {
        self.redo.pop()
    }

    /// Puts a redone step back on the undo stack, without dropping anything: its bytes were
    /// already counted.
    pub fn push_undo_again(&mut self, step: Step) {
        self.undo.push_back(step);
    }
}
