//! The egui application: panels, menus and the canvas and preview widgets. It holds no numerics.
