//! The analysis as `tables.md` states it: the fits of every lens metric with their intervals and
//! directions, the ODE's paired differences from each baseline in plain words, the same over the
//! learned models and over each model alone, and the rank stability per level.

use super::predictors::{Comparison, Estimate, LensMetric, Predictors};
use super::ranks::LevelRanks;
use super::{Analysis, LensAnalysis};

fn number(v: Option<f64>) -> String {
    v.map_or("n/a".to_string(), |v| format!("{v:.3}"))
}

fn with_interval(e: &Estimate) -> String {
    match (e.value, e.ci95) {
        (Some(v), Some([lo, hi])) => format!("{v:.3} [{lo:.3}, {hi:.3}]"),
        (v, _) => number(v),
    }
}

fn fits_table(p: &Predictors) -> String {
    let mut out = String::from(
        "| lens metric | R^2 [95%] | Pearson r [95%] | slope | Spearman rho [95%] | Kendall tau [95%] | direction |\n|---|---|---|---:|---|---|---|\n",
    );
    for m in &p.metrics {
        let direction = match m.direction_expected() {
            Some(true) => "as expected",
            Some(false) => "**inverse**",
            None => "n/a",
        };
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {direction} |\n",
            m.metric.label(),
            with_interval(&m.r2),
            with_interval(&m.pearson),
            number(m.fit.map(|f| f.slope)),
            with_interval(&m.spearman),
            with_interval(&m.kendall),
        ));
    }
    out
}

/// "higher by 0.100 [0.020, 0.200] (the ODE is better, the interval excludes 0)" and the like.
fn verdict(e: &Estimate) -> String {
    match (e.value, e.ci95) {
        (Some(v), Some([lo, hi])) => {
            let side = if v >= 0.0 { "higher" } else { "lower" };
            let decided = if lo > 0.0 {
                "the ODE is better, the interval excludes 0"
            } else if hi < 0.0 {
                "the baseline is better, the interval excludes 0"
            } else {
                "not decided, the interval includes 0"
            };
            format!("{side} by {:.3} [{lo:.3}, {hi:.3}] ({decided})", v.abs())
        }
        _ => "not defined on these lenses".to_string(),
    }
}

fn comparison_sentences(c: &Comparison) -> String {
    format!(
        "- ODE against {}: R^2 {}; rank correlation (Spearman) {}; (Kendall) {}.\n",
        c.baseline.label(),
        verdict(&c.r2_diff),
        verdict(&c.spearman_diff),
        verdict(&c.kendall_diff),
    )
}

fn direction_warnings(p: &Predictors) -> String {
    let mut out = String::new();
    for m in &p.metrics {
        if m.direction_expected() == Some(false) {
            let (rises, expected) = match m.metric {
                LensMetric::Ode => ("rises", "should rise with it"),
                _ => ("grows", "should fall as it grows"),
            };
            out.push_str(&format!(
                "\n**Direction:** O.P. moves against the {label}'s meaning here (Pearson r = {r}): as the {label} {rises}, restorability goes the wrong way (it {expected}). Its R^2 measures an inverse relation and does not support the {label} as a predictor.\n",
                label = m.metric.label(),
                r = number(m.pearson.value),
            ));
        }
    }
    out
}

fn predictors_section(title: &str, a: &LensAnalysis) -> String {
    let p = &a.predictors;
    let mut out = format!(
        "\n#### {title}\n\nPer-lens mean O.P. of {} over {} lenses.\n\n",
        a.models.join(", "),
        p.lenses
    );
    out.push_str(&fits_table(p));
    out.push_str(&direction_warnings(p));
    out.push_str("\nThe ODE against each baseline, paired bootstrap over the same lens resamples (rank correlations taken in each metric's supporting direction):\n\n");
    for c in &p.comparisons {
        out.push_str(&comparison_sentences(c));
    }
    out
}

fn per_model_table(a: &Analysis) -> String {
    let mut out = String::from(
        "\n#### Each model alone\n\n| model | lenses | R^2 ODE | R^2 log RMS | R^2 ODE - log RMS [95%] | Spearman ODE | direction ODE |\n|---|---:|---:|---:|---|---:|---|\n",
    );
    for (model, m) in &a.per_model {
        let p = &m.predictors;
        let ode = p.metric(LensMetric::Ode);
        let direction = match ode.direction_expected() {
            Some(true) => "as expected",
            Some(false) => "**inverse**",
            None => "n/a",
        };
        out.push_str(&format!(
            "| {model} | {} | {} | {} | {} | {} | {direction} |\n",
            p.lenses,
            number(ode.r2.value),
            number(p.metric(LensMetric::LogRmsRadius).r2.value),
            p.comparison(LensMetric::LogRmsRadius)
                .map_or("n/a".into(), |c| with_interval(&c.r2_diff)),
            number(ode.spearman.value),
        ));
    }
    out
}

fn ranks_table(levels: &[LevelRanks]) -> String {
    let Some(first) = levels.first() else {
        return String::new();
    };
    let mut out = format!(
        "\n### Rank stability per ODE level\n\nEach level's ranks by O.P. (without FID) recomputed on {} bootstrap resamples of its lenses and, within each lens, of its scenes (the same draws for every model). A rank whose share is low, or whose interval spans several places, is within the noise of the test set.\n\n| level | lenses | model | O.P. | rank | rank 95% | share at this rank | share ranked first |\n|---:|---:|---|---:|---:|---|---:|---:|\n",
        first.resamples
    );
    for level in levels {
        let mut models: Vec<_> = level.models.iter().collect();
        models.sort_by_key(|m| m.rank);
        for m in models {
            out.push_str(&format!(
                "| {} | {} | {} | {:.4} | {} | {}-{} | {:.2} | {:.2} |\n",
                level.level,
                level.lenses,
                m.model,
                m.op,
                m.rank,
                m.rank_ci95[0],
                m.rank_ci95[1],
                m.rank_share,
                m.best_share
            ));
        }
    }
    out
}

/// The analysis section of `tables.md`.
pub fn markdown(a: &Analysis) -> String {
    let mut out = String::from("\n### Which lens metric predicts restorability?\n");
    out.push_str(&predictors_section("All restoration methods", &a.all));
    if let Some(learned) = &a.learned_only {
        out.push_str(&predictors_section("Learned models only", learned));
    }
    out.push_str(&per_model_table(a));
    out.push_str(&format!(
        "\nIntervals: percentile bootstrap over lenses, {} resamples, seeded.\n",
        a.bootstrap_resamples
    ));
    out.push_str(&ranks_table(&a.rank_stability));
    out
}
