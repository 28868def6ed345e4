//! Change batches and undo: the tiles an edit touches are captured before it changes them,
//! so that an edit becomes one undo step and the changed pixels can be reported.

use super::{Batch, BatchTile, Canvas, Edit, NO_SLOT};
use crate::paint::changes::{CanvasChanges, PixelChange, PixelRect};
use crate::paint::history::{Step, TileData, TileGrid};
use crate::paint::layers::PaintLayers;

impl Canvas {
    /// The changes since the last call (or since the canvas was made): each pixel whose
    /// painted state or colour changed, with its state when the batch began, and the
    /// rectangle holding them. `None` when nothing changed.
    pub fn take_changes(&mut self) -> Option<CanvasChanges> {
        let width = self.resolution();
        let mut pixels = Vec::new();
        let (mut x0, mut y0, mut x1, mut y1) = (u32::MAX, u32::MAX, 0, 0);
        for tile in self.batch.tiles.drain(..) {
            self.batch.slot[tile.before.tile] = NO_SLOT;
            let rect = self.grid.rect(tile.before.tile);
            let tile_width = rect.width() as usize;
            let t = tile.touched;
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    let i = y as usize * width + x as usize;
                    let l = (y - rect.y0) as usize * tile_width + (x - rect.x0) as usize;
                    let before = painted(tile.before.colour[l], tile.before.coverage[l]);
                    let after = painted(self.layers.colour.pixels[i], self.layers.coverage[i]);
                    if !same_state(before, after) {
                        pixels.push(PixelChange {
                            pixel: i as u32,
                            before,
                            after,
                        });
                        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
                    }
                }
            }
        }
        if pixels.is_empty() {
            return None;
        }
        pixels.sort_unstable_by_key(|p| p.pixel);
        Some(CanvasChanges {
            dirty: PixelRect::new(x0, y0, x1, y1),
            pixels,
        })
    }

    pub fn can_undo(&self) -> bool {
        self.history.can_undo() || self.stroke.as_ref().is_some_and(|s| !s.edit.is_empty())
    }

    pub fn can_redo(&self) -> bool {
        self.history.can_redo()
    }

    /// How many steps can be undone (a stroke in progress not counted).
    pub fn undo_steps(&self) -> usize {
        self.history.undo_len()
    }

    /// Bytes the undo and redo history holds.
    pub fn undo_bytes(&self) -> usize {
        self.history.bytes()
    }

    /// Bounds the memory of the undo and redo history (default [`DEFAULT_UNDO_BUDGET`]);
    /// the oldest steps are dropped to keep under it. A single step larger than the whole
    /// budget is not kept.
    pub fn set_undo_budget(&mut self, bytes: usize) {
        self.history.set_budget(bytes);
    }

    /// Undoes the last stroke or fill (ending a stroke in progress first), restoring colour
    /// and coverage bit for bit. Returns the batch of changes, drained (including any not
    /// yet taken); `None` when there is nothing to undo.
    pub fn undo(&mut self) -> Option<CanvasChanges> {
        self.end_stroke();
        let mut step = self.history.pop_undo()?;
        self.swap_in(&mut step);
        self.history.push_redo(step);
        Some(self.take_changes().unwrap_or_default())
    }

    /// Reapplies the last undone step exactly. Returns the drained batch of changes; `None`
    /// when there is nothing to redo.
    pub fn redo(&mut self) -> Option<CanvasChanges> {
        self.end_stroke();
        let mut step = self.history.pop_redo()?;
        self.swap_in(&mut step);
        self.history.push_undo_again(step);
        Some(self.take_changes().unwrap_or_default())
    }

    fn swap_in(&mut self, step: &mut Step) {
        let width = self.resolution();
        for data in &mut step.tiles {
            let rect = self.grid.rect(data.tile);
            self.batch.touch(&self.layers, &self.grid, data.tile, rect);
            data.swap_with(&mut self.layers, &self.grid);
            // The step may date from another base (a prediction put under the paint since):
            // what it leaves unpainted shows the base of now.
            for y in rect.y0 as usize..rect.y1 as usize {
                for i in y * width + rect.x0 as usize..y * width + rect.x1 as usize {
                    if self.layers.coverage[i] == 0.0 {
                        self.layers.colour.pixels[i] = self.base.pixels[i];
                    }
                }
            }
        }
    }

    /// Records the tiles an edit changed as one undo step; tiles it touched but left as they
    /// were are dropped.
    pub(super) fn commit(&mut self, edit: Edit) {
        let tiles: Vec<TileData> = edit
            .before
            .into_iter()
            .filter(|t| !t.same_as(&self.layers, &self.grid))
            .collect();
        if !tiles.is_empty() {
            self.history.push(Step { tiles });
        }
    }

    /// Makes sure the edit and the change batch hold `tile` as it was before they touched it,
    /// and notes that `rect` of it may change. Returns the tile's slot in the edit.
    pub(super) fn touch(&mut self, edit: &mut Edit, tile: usize, rect: PixelRect) -> usize {
        if edit.slot[tile] == NO_SLOT {
            if edit.before.is_empty() {
                // The first change of a new edit: what was undone can no longer be redone.
                self.history.clear_redo();
            }
            edit.slot[tile] = edit.before.len() as u32;
            let data = TileData::capture(&self.layers, &self.grid, tile);
            edit.accumulated.push(vec![0.0; data.coverage.len()]);
            edit.before.push(data);
        }
        self.batch.touch(&self.layers, &self.grid, tile, rect);
        edit.slot[tile] as usize
    }
}

impl Batch {
    fn touch(&mut self, layers: &PaintLayers, grid: &TileGrid, tile: usize, rect: PixelRect) {
        match self.slot[tile] {
            NO_SLOT => {
                self.slot[tile] = self.tiles.len() as u32;
                self.tiles.push(BatchTile {
                    before: TileData::capture(layers, grid, tile),
                    touched: rect,
                });
            }
            slot => {
                let entry = &mut self.tiles[slot as usize];
                entry.touched = entry.touched.union(&rect);
            }
        }
    }
}

impl Edit {
    pub(super) fn new(tiles: usize) -> Self {
        Self {
            slot: vec![NO_SLOT; tiles],
            before: Vec::new(),
            accumulated: Vec::new(),
        }
    }

    fn is_empty(&self) -> bool {
        self.before.is_empty()
    }
}

/// A pixel's state as the app sees it: its colour if painted.
#[inline]
fn painted(colour: [f32; 3], coverage: f32) -> Option<[f32; 3]> {
    (coverage > 0.0).then_some(colour)
}

fn same_state(a: Option<[f32; 3]>, b: Option<[f32; 3]>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => a.map(f32::to_bits) == b.map(f32::to_bits),
        _ => false,
    }
}
