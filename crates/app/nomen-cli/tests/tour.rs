//! README's short tour and `scripts/tour.sh` (which `.ci/run` runs) list the same commands in the
//! same order, so that what CI runs is what a newcomer reads.

use std::path::Path;

/// The commands of a shell text: comments dropped, `\` continuations joined, whitespace
/// collapsed; lines that do not start with `nomen ` (or the script's `run nomen ` /
/// `long nomen `) are not commands of the tour.
fn commands(text: &str) -> Vec<String> {
    let mut joined = Vec::new();
    let mut current = String::new();
    for line in text.lines() {
        let line = match line.find(" # ") {
            Some(k) => &line[..k],
            None => line,
        };
        let line = line.trim();
        if line.starts_with('#') {
            continue;
        }
        match line.strip_suffix('\\') {
            Some(head) => {
                current.push_str(head);
                current.push(' ');
            }
            None => {
                current.push_str(line);
                joined.push(std::mem::take(&mut current));
            }
        }
    }
    joined
        .iter()
        .map(|l| l.split_whitespace().collect::<Vec<_>>().join(" "))
        .filter_map(|l| {
            let l = l
                .strip_prefix("run ")
                .or_else(|| l.strip_prefix("long "))
                .unwrap_or(&l)
                .to_owned();
            l.starts_with("nomen ").then_some(l)
        })
        .collect()
}

#[test]
fn readme_tour_and_the_tour_script_run_the_same_commands_in_order() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
    let readme = std::fs::read_to_string(repo.join("README.md")).unwrap();
    let start = readme.find("## A short tour").expect("README has a tour");
    let tour = &readme[start..];
    let block_start = tour.find("```sh").expect("the tour's code block") + "```sh".len();
    let block_end = block_start + tour[block_start..].find("```").expect("block end");
    let readme_commands = commands(&tour[block_start..block_end]);
    let script = std::fs::read_to_string(repo.join("scripts/tour.sh")).unwrap();
    let script_commands = commands(&script);
    assert!(readme_commands.len() >= 40, "{readme_commands:#?}");
    assert_eq!(readme_commands, script_commands);
}

#[test]
fn commands_drop_comments_and_join_continuations() {
    let text = "# a comment\nnomen a \\\n  --b c   # note\nrun nomen d\nlong nomen e\necho f\n";
    assert_eq!(commands(text), ["nomen a --b c", "nomen d", "nomen e"]);
}
