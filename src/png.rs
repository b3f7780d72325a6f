//! PNG charts drawn with plotters in the bundled font and written atomically.

use std::path::Path;

use plotters::coord::Shift;
use plotters::drawing::DrawingAreaErrorKind;
use plotters::prelude::*;

/// The drawing area of a PNG being drawn.
pub type Drawing<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// What drawing on it can fail with.
pub type DrawError =
    DrawingAreaErrorKind<<BitMapBackend<'static> as plotters::backend::DrawingBackend>::ErrorType>;

/// Draws a PNG of `size` pixels (white background) with `draw` into `path`, atomically.
pub fn png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Drawing<'_>) -> Result<(), DrawError>,
) -> std::io::Result<()> {
    crate::font::register();
    foosball_nets::atomic_file::replace_file(path, |tmp| {
        let root = BitMapBackend::new(tmp, size).into_drawing_area();
        root.fill(&WHITE)
            .and_then(|()| draw(&root))
            .and_then(|()| root.present())
            .map_err(|e| std::io::Error::other(e.to_string()))
    })
}
