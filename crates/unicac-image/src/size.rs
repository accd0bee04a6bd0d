//! Image sizes as the faces write them: `WxH` in pixels (`640x480`; `X` accepted too). The one parser;
//! each caller applies its own limit (a dataset frame's side, a chart's pixel count).

/// `WxH` with both sides positive integers.
pub fn parse_wxh(text: &str) -> Result<[usize; 2], String> {
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size {text:?} is not WxH (e.g. 640x480)"))?;
    let side = |s: &str| s.trim().parse::<usize>().ok().filter(|&v| v > 0);
    match (side(w), side(h)) {
        (Some(w), Some(h)) => Ok([w, h]),
        _ => Err(format!(
            "size {text:?}: width and height must be positive integers"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_bad_ones_are_named() {
        assert_eq!(parse_wxh("640x480"), Ok([640, 480]));
        assert_eq!(parse_wxh("8X6"), Ok([8, 6]));
        for bad in ["640", "0x4", "4x-1", "ax4", "4x", ""] {
            assert!(parse_wxh(bad).unwrap_err().contains(&format!("{bad:?}")), "{bad}");
        }
    }
}
