//! Every command of the README's tour runs: the `sh` block under "## A short tour" is read from README.md
//! (so an edited README is what gets tested) and each line is run in a scratch directory, with smaller
//! images and budgets so the whole tour takes seconds (the substitutions are listed in `shrink`); a line
//! ending in a backslash continues on the next. The README's first block (`bash scripts/demo.sh`, `bash scripts/test.sh`) is the project's own CI entry
//! and demo, run by CI itself, not here.

use std::path::Path;
use std::process::Command;

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// The command lines of the tour, comments dropped.
fn tour_commands() -> Vec<String> {
    let readme = std::fs::read_to_string(Path::new(ROOT).join("README.md")).unwrap();
    let tour = readme
        .split("## A short tour")
        .nth(1)
        .expect("README has a tour section");
    let block = tour
        .split("```sh")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("the tour has an sh block");
    // A line ending in a backslash continues on the next one, as in the shell.
    let mut commands = Vec::new();
    let mut pending = String::new();
    for line in block.lines() {
        let code = line.split(" #").next().unwrap_or("").trim();
        match code.strip_suffix('\\') {
            Some(head) => {
                pending.push_str(head);
                pending.push(' ');
            }
            None => {
                pending.push_str(code);
                let command = pending.trim().to_string();
                if !command.is_empty() {
                    commands.push(command);
                }
                pending.clear();
            }
        }
    }
    commands
}

/// The same command with test-sized arguments: small charts, a short design budget, lens files from the
/// repository and scratch paths instead of /tmp.
fn shrink(args: &[&str], scratch: &Path) -> Vec<String> {
    args.iter()
        .enumerate()
        .map(|(i, &arg)| match (i.checked_sub(1).map(|p| args[p]), arg) {
            (Some("--size"), _) => "256x192".to_string(),
            (Some("--time-budget-s"), _) => "3".to_string(),
            (Some("--count"), _) => "1".to_string(),
            (Some("--trials"), _) => "4".to_string(),
            (Some("--images"), _) => "dead-leaves:2:80x60".to_string(),
            (Some("--test-images"), _) => "dead-leaves:1:64x48".to_string(),
            (Some("--crop"), _) => "32x24".to_string(),
            (Some("--model"), a) if a.contains("=models/") => {
                let (name, path) = a.split_once('=').unwrap();
                format!("{name}={}", Path::new(ROOT).join(path).display())
            }
            (_, a) if ["lenses/", "models/", "docs/"].iter().any(|p| a.starts_with(p)) => {
                Path::new(ROOT).join(a).display().to_string()
            }
            (_, a) if a.starts_with("/tmp/") => scratch.join(&a[5..]).display().to_string(),
            (_, a) => a.to_string(),
        })
        .collect()
}

#[test]
fn every_command_of_the_readme_tour_runs() {
    let scratch = std::env::temp_dir().join(format!("unicac-readme-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).unwrap();
    let commands = tour_commands();
    assert!(commands.len() >= 10, "the tour lost its commands: {commands:?}");
    for line in &commands {
        let words: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(
            words[0], "unicac",
            "a tour line that is not a unicac command: {line}"
        );
        // `bench` loads onnxruntime at run time; scripts/test.sh provides it (ORT_DYLIB_PATH).
        if words[1] == "bench" && std::env::var_os("ORT_DYLIB_PATH").is_none() {
            eprintln!("skipped without ORT_DYLIB_PATH: {line}");
            continue;
        }
        let args = shrink(&words[1..], &scratch);
        let output = Command::new(env!("CARGO_BIN_EXE_unicac"))
            .args(&args)
            .current_dir(&scratch)
            .env("UNICAC_CACHE_DIR", scratch.join("cache"))
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "README command failed: {line}\n(run as {args:?})\n{}",
            String::from_utf8_lossy(&output.stderr)
        );
    }
    // The tour's last image step measures the simulated edge: its output is an MTF.
    let mtf_line = commands.iter().find(|l| l.starts_with("unicac mtf")).unwrap();
    assert!(mtf_line.contains("simulated/edge"), "{mtf_line}");
    std::fs::remove_dir_all(&scratch).ok();
}
