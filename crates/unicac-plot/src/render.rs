//! Choosing the backend from the file name and writing the file atomically.

use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// A picture: its size in pixels and how to draw it on any backend.
pub(crate) trait Picture {
    fn size(&self) -> (u32, u32);

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static;
}

/// Draws `picture` into `path`, as PNG or SVG according to the extension. The file appears complete or
/// not at all: the picture is drawn to a temporary sibling (PNG) or to memory (SVG) and renamed into place.
pub(crate) fn render(picture: &impl Picture, path: &Path) -> Result<(), PlotError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("svg") => {
            let mut svg = String::new();
            draw_on(
                picture,
                SVGBackend::with_string(&mut svg, picture.size()).into_drawing_area(),
            )?;
            Ok(unicac_optics::io::write_atomically(path, svg.as_bytes())?)
        }
        Some("png") => {
            // The bitmap backend writes on drop even after an error, hence the temporary file.
            let temporary = temporary_sibling(path);
            let result = draw_on(
                picture,
                BitMapBackend::new(&temporary, picture.size()).into_drawing_area(),
            )
            .and_then(|()| {
                std::fs::rename(&temporary, path).map_err(|source| PlotError::Io {
                    path: path.into(),
                    source,
                })
            });
            if result.is_err() {
                let _ = std::fs::remove_file(&temporary);
            }
            result
        }
        _ => Err(PlotError::UnknownExtension {
            path: path.to_path_buf(),
        }),
    }
}

fn draw_on<DB: DrawingBackend>(picture: &impl Picture, root: DrawingArea<DB, Shift>) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    picture.draw(root.clone())?;
    root.present()?;
    Ok(())
}

/// `.name.tmp-PID.png` next to `path` (the bitmap encoder picks its format from the extension).
fn temporary_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}.png", std::process::id()))
}
