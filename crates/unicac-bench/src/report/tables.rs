//! Per-level tables as Markdown and LaTeX, laid out like the paper's Table 2: one row per model, for each
//! level the columns PSNR, SSIM, LPIPS and O.P.; in each column the best value is bold and the second
//! best underlined (higher is better except for LPIPS). Missing values print as "-".

use super::ResultRow;
use crate::Benchmark;

/// The table columns: header, value, higher is better, decimals.
type Column = (&'static str, fn(&ResultRow) -> Option<f64>, bool, usize);

const COLUMNS: [Column; 4] = [
    ("PSNR", |r| r.psnr_db, true, 2),
    ("SSIM", |r| r.ssim, true, 4),
    ("LPIPS", |r| r.lpips, false, 4),
    ("O.P.", |r| r.op, true, 4),
];

#[derive(Clone, Copy, PartialEq)]
enum Mark {
    Best,
    Second,
    Plain,
}

/// The cells of one benchmark's table: models x (levels x columns), with their marks.
fn cells(rows: &[ResultRow], models: &[String], benchmark: Benchmark) -> (Vec<u8>, Vec<Vec<(String, Mark)>>) {
    let levels: Vec<u8> = (1..=super::LEVELS)
        .filter(|l| rows.iter().any(|r| r.benchmark == benchmark && r.level == *l))
        .collect();
    let find = |model: &str, level: u8| {
        rows.iter()
            .find(|r| r.model == model && r.benchmark == benchmark && r.level == level)
    };
    let mut table = vec![Vec::new(); models.len()];
    for &level in &levels {
        for (_, value, higher, decimals) in COLUMNS {
            let values: Vec<Option<f64>> = models.iter().map(|m| find(m, level).and_then(value)).collect();
            let mut ranked: Vec<f64> = values.iter().flatten().copied().collect();
            ranked.sort_by(|a, b| if higher { b.total_cmp(a) } else { a.total_cmp(b) });
            ranked.dedup();
            for (i, v) in values.iter().enumerate() {
                let cell = match v {
                    Some(v) => {
                        let mark = if Some(v) == ranked.first() && models.len() > 1 {
                            Mark::Best
                        } else if Some(v) == ranked.get(1) && models.len() > 2 {
                            Mark::Second
                        } else {
                            Mark::Plain
                        };
                        (format!("{v:.decimals$}"), mark)
                    }
                    None => ("-".to_string(), Mark::Plain),
                };
                table[i].push(cell);
            }
        }
    }
    (levels, table)
}

/// The Markdown table of `benchmark`.
pub fn markdown(rows: &[ResultRow], models: &[String], benchmark: Benchmark) -> String {
    let (levels, table) = cells(rows, models, benchmark);
    let mut out = format!("### Benchmark `{benchmark}`\n\n| model |");
    for level in &levels {
        for (name, ..) in COLUMNS {
            out.push_str(&format!(" L{level} {name} |"));
        }
    }
    out.push_str("\n|---|");
    out.push_str(&"---:|".repeat(levels.len() * COLUMNS.len()));
    out.push('\n');
    for (model, cells) in models.iter().zip(&table) {
        out.push_str(&format!("| {model} |"));
        for (text, mark) in cells {
            let text = match mark {
                Mark::Best => format!("**{text}**"),
                Mark::Second => format!("<u>{text}</u>"),
                Mark::Plain => text.clone(),
            };
            out.push_str(&format!(" {text} |"));
        }
        out.push('\n');
    }
    out
}

fn latex_escape(text: &str) -> String {
    text.replace('\\', "\\textbackslash{}")
        .replace('_', "\\_")
        .replace('&', "\\&")
        .replace('%', "\\%")
        .replace('#', "\\#")
}

/// The LaTeX table (booktabs) of `benchmark`.
pub fn latex(rows: &[ResultRow], models: &[String], benchmark: Benchmark) -> String {
    let (levels, table) = cells(rows, models, benchmark);
    let columns = levels.len() * COLUMNS.len();
    let mut out = format!(
        "% unicac bench, benchmark {benchmark}: best bold, second underlined\n\\begin{{tabular}}{{l{}}}\n\\toprule\n",
        "c".repeat(columns)
    );
    out.push_str("Model");
    for level in &levels {
        out.push_str(&format!(
            " & \\multicolumn{{{}}}{{c}}{{Level {level}}}",
            COLUMNS.len()
        ));
    }
    out.push_str(" \\\\\n");
    for (name, _, higher, _) in COLUMNS.iter().cycle().take(columns).map(|c| (c.0, c.1, c.2, c.3)) {
        let arrow = if higher { "$\\uparrow$" } else { "$\\downarrow$" };
        out.push_str(&format!(" & {name}{arrow}"));
    }
    out.push_str(" \\\\\n\\midrule\n");
    for (model, cells) in models.iter().zip(&table) {
        out.push_str(&latex_escape(model));
        for (text, mark) in cells {
            let text = match mark {
                Mark::Best => format!("\\textbf{{{text}}}"),
                Mark::Second => format!("\\underline{{{text}}}"),
                Mark::Plain => text.clone(),
            };
            out.push_str(&format!(" & {text}"));
        }
        out.push_str(" \\\\\n");
    }
    out.push_str("\\bottomrule\n\\end{tabular}\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(model: &str, level: u8, psnr: f64, lpips: f64) -> ResultRow {
        ResultRow {
            model: model.into(),
            benchmark: Benchmark::Ode,
            level,
            pairs: 1,
            psnr_db: Some(psnr),
            ssim: Some(0.5),
            lpips: Some(lpips),
            oiqe: None,
            fid: None,
            clipiqa: None,
            op: Some(psnr / 100.0),
            op_terms: vec!["psnr"],
            op_complete: false,
        }
    }

    #[test]
    fn best_is_bold_and_second_underlined_with_lpips_lower_better() {
        let rows = vec![
            row("a", 1, 20.0, 0.3),
            row("b", 1, 25.0, 0.1),
            row("c", 1, 22.0, 0.2),
        ];
        let models: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let md = markdown(&rows, &models, Benchmark::Ode);
        assert!(md.contains("| b | **25.00** |"), "{md}");
        assert!(md.contains("| c | <u>22.00</u> |"), "{md}");
        assert!(md.contains("**0.1000**") && md.contains("<u>0.2000</u>"), "{md}");
        let tex = latex(&rows, &models, Benchmark::Ode);
        assert!(
            tex.contains("\\textbf{25.00}") && tex.contains("\\underline{22.00}"),
            "{tex}"
        );
        assert!(tex.contains("LPIPS$\\downarrow$"), "{tex}");
    }
}
