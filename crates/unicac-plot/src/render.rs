//! Choosing the backend from the file name and writing the file atomically.

use crate::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

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
    // A missing folder is reported with the path, not as the backend's debug structure.
    let folder = path.parent().filter(|p| !p.as_os_str().is_empty());
    if let Some(folder) = folder.filter(|f| !f.is_dir()) {
        return Err(PlotError::Io {
            path: path.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                format!("the folder {} does not exist", folder.display()),
            ),
        });
    }
    render_file(picture, path).map_err(|error| match error {
        PlotError::Backend(message) => PlotError::Backend(format!("{}: {message}", path.display())),
        other => other,
    })
}

fn render_file(picture: &impl Picture, path: &Path) -> Result<(), PlotError> {
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
            // The bitmap backend writes on drop even after an error, hence the temporary file (named
            // with the .png extension the backend picks its encoder from).
            let mut failure = None;
            let written = unicac_io::write_via_path(path, |temporary| {
                draw_on(
                    picture,
                    BitMapBackend::new(temporary, picture.size()).into_drawing_area(),
                )
                .map_err(|e| {
                    failure = Some(e);
                    std::io::Error::other("drawing failed")
                })
            });
            match (written, failure) {
                (_, Some(error)) => Err(error),
                (Err(source), None) => Err(PlotError::Io {
                    path: path.into(),
                    source,
                }),
                (Ok(()), None) => Ok(()),
            }
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
