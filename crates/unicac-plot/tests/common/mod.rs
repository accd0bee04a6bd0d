//! Helpers shared by the picture tests: a scratch directory and the checks every picture passes.

use std::path::{Path, PathBuf};
use unicac_plot::PlotError;

/// A fresh directory, removed when dropped.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("unicac-plot-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    pub fn files(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The number in `attribute="..."` of the SVG's opening tag.
fn svg_attribute(svg: &str, attribute: &str) -> u32 {
    let tag = &svg[..svg.find('>').unwrap()];
    let start = tag.find(&format!(" {attribute}=\"")).unwrap() + attribute.len() + 3;
    tag[start..].split('"').next().unwrap().parse().unwrap()
}

/// Renders `name`.png and `name`.svg with `draw` and checks both files; `texts` must appear in the SVG.
pub fn check_both_formats(name: &str, texts: &[&str], draw: impl Fn(&Path) -> Result<(), PlotError>) {
    let dir = TempDir::new(name);
    let (png_path, svg_path) = (
        dir.0.join(format!("{name}.png")),
        dir.0.join(format!("{name}.SVG")),
    );
    draw(&png_path).unwrap();
    draw(&svg_path).unwrap();
    assert_eq!(
        dir.files(),
        [format!("{name}.SVG"), format!("{name}.png")],
        "only the two pictures"
    );

    let svg = std::fs::read_to_string(&svg_path).unwrap();
    assert!(svg.len() > 10_000, "SVG of {} bytes", svg.len());
    assert!(
        svg.starts_with("<svg ") && svg.trim_end().ends_with("</svg>"),
        "SVG is complete"
    );
    assert_eq!(svg.matches("<text").count(), svg.matches("</text>").count());
    for text in texts {
        assert!(svg.contains(text), "SVG lacks '{text}'");
    }
    let (width, height) = (svg_attribute(&svg, "width"), svg_attribute(&svg, "height"));
    assert!(width >= 600 && height >= 300, "{width} x {height}");

    let png = std::fs::read(&png_path).unwrap();
    assert!(png.len() > 10_000, "PNG of {} bytes", png.len());
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&png[12..16], b"IHDR");
    let be = |at: usize| u32::from_be_bytes(png[at..at + 4].try_into().unwrap());
    assert_eq!(
        (be(16), be(20)),
        (width, height),
        "PNG and SVG have the picture's size"
    );
}
