//! `report.html`: one self-contained page with the tables and the pictures (embedded as base64 PNG), for
//! opening or mailing without the rest of REPORT_DIR.

use std::path::Path;

const BASE64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 with padding (RFC 4648).
pub fn base64(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(BASE64[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Markdown cell text to HTML: `**x**` bold, `<u>x</u>` kept, the rest escaped.
fn cell(text: &str) -> String {
    let text = text.trim();
    if let Some(inner) = text.strip_prefix("**").and_then(|t| t.strip_suffix("**")) {
        return format!("<b>{}</b>", escape(inner));
    }
    if let Some(inner) = text.strip_prefix("<u>").and_then(|t| t.strip_suffix("</u>")) {
        return format!("<u>{}</u>", escape(inner));
    }
    escape(text).replace('`', "")
}

/// The page for `markdown` (the tables.md text) and the pictures in `dir` named `pictures`.
pub fn page(markdown: &str, dir: &Path, pictures: &[&str]) -> String {
    let mut html = String::from(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>unicac bench</title><style>\
         body{font-family:sans-serif;margin:2em;max-width:1400px}table{border-collapse:collapse;margin:1em 0}\
         td,th{border:1px solid #ccc;padding:3px 7px;text-align:right}td:first-child,th:first-child{text-align:left}\
         img{max-width:100%;margin:1em 0}</style></head><body>\n",
    );
    let mut in_table = false;
    for line in markdown.lines() {
        if line.starts_with('|') {
            let cells: Vec<&str> = line.trim_matches('|').split('|').collect();
            if cells
                .iter()
                .all(|c| c.trim().chars().all(|ch| ch == '-' || ch == ':'))
            {
                continue;
            }
            let tag = if in_table { "td" } else { "th" };
            if !in_table {
                html.push_str("<table>\n");
                in_table = true;
            }
            html.push_str("<tr>");
            for c in cells {
                html.push_str(&format!("<{tag}>{}</{tag}>", cell(c)));
            }
            html.push_str("</tr>\n");
            continue;
        }
        if in_table {
            html.push_str("</table>\n");
            in_table = false;
        }
        if let Some(h) = line.strip_prefix("### ") {
            html.push_str(&format!("<h3>{}</h3>\n", cell(h)));
        } else if let Some(h) = line.strip_prefix("# ") {
            html.push_str(&format!("<h1>{}</h1>\n", escape(h)));
        } else if let Some(item) = line.strip_prefix("- ") {
            html.push_str(&format!("<p>&bull; {}</p>\n", escape(item)));
        } else if !line.trim().is_empty() {
            html.push_str(&format!(
                "<p>{}</p>\n",
                escape(line)
                    .replace("**bold**", "<b>bold</b>")
                    .replace("&lt;u&gt;underlined&lt;/u&gt;", "<u>underlined</u>")
            ));
        }
    }
    if in_table {
        html.push_str("</table>\n");
    }
    for name in pictures {
        if let Ok(bytes) = std::fs::read(dir.join(name)) {
            html.push_str(&format!(
                "<h3>{name}</h3><img alt=\"{name}\" src=\"data:image/png;base64,{}\">\n",
                base64(&bytes)
            ));
        }
    }
    html.push_str("</body></html>\n");
    html
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_of_rfc_4648_vectors() {
        for (input, output) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(input.as_bytes()), output);
        }
    }

    #[test]
    fn tables_become_html_with_marks() {
        let html = page(
            "# t\n\n| model | PSNR |\n|---|---:|\n| a | **20.00** |\n| b | <u>19.00</u> |\n",
            Path::new("."),
            &[],
        );
        assert!(
            html.contains("<th>model</th>")
                && html.contains("<td><b>20.00</b></td>")
                && html.contains("<td><u>19.00</u></td>"),
            "{html}"
        );
    }
}
