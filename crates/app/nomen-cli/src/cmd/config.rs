//! `nomen config defaults`: the engine's configuration (the TOML that `--config` reads) with every
//! key at its default, each preceded by its documentation, which comes from the configuration
//! types' own doc comments through their JSON schema (`schemars`).

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use nomen_engine::EngineConfig;
use serde_json::Value as Json;
use std::io::Write;

/// `nomen config` subcommands.
#[derive(Debug, Subcommand)]
pub enum ConfigCommand {
    /// Print the engine's configuration with every key at its default and documented: a file
    /// for `nomen run --config` (and `serve`, `bench`), to edit.
    Defaults(DefaultsArgs),
}

/// Arguments of `nomen config defaults`.
#[derive(Debug, Args)]
pub struct DefaultsArgs {
    /// Print the configuration's JSON schema (types, defaults, every key's documentation)
    /// instead.
    #[arg(long)]
    pub json_schema: bool,
}

/// Runs a `nomen config` subcommand.
pub fn run(command: ConfigCommand) -> Result<()> {
    match command {
        ConfigCommand::Defaults(args) => {
            let text = if args.json_schema {
                serde_json::to_string_pretty(&schema()?)? + "\n"
            } else {
                defaults_toml()?
            };
            std::io::stdout()
                .lock()
                .write_all(text.as_bytes())
                .context("cannot write to stdout")
        }
    }
}

/// The JSON schema of [`EngineConfig`].
fn schema() -> Result<Json> {
    serde_json::to_value(schemars::schema_for!(EngineConfig)).context("the config's schema")
}

/// Width of the comment lines.
const WIDTH: usize = 100;

/// The default configuration as commented TOML.
pub fn defaults_toml() -> Result<String> {
    let schema = schema()?;
    let defaults = toml::Table::try_from(EngineConfig::default())
        .context("the default configuration as TOML")?;
    let mut out = String::new();
    out.push_str(
        "# nomen's engine configuration, every key at its default (`nomen config defaults`).\n\
         # Give `nomen run --config FILE` (and `serve`, `bench`) a file with the keys to change;\n\
         # a key left out keeps its default, and an unknown key is an error.\n",
    );
    render_table(&mut out, &defaults, &schema, &schema, "");
    Ok(out)
}

/// Writes `table` (at TOML path `path`, "" for the root) documented from `node`, its schema;
/// `root` holds the definitions that references point to.
fn render_table(out: &mut String, table: &toml::Table, node: &Json, root: &Json, path: &str) {
    let node = resolve(node, root);
    let properties = node.get("properties").and_then(Json::as_object);
    let doc_of = |key: &str| {
        properties
            .and_then(|p| p.get(key))
            .map(|p| description(p, root))
            .unwrap_or_default()
    };
    // Plain keys first: TOML puts a table's own keys before its sub-tables.
    for (key, value) in table.iter().filter(|(_, v)| !v.is_table()) {
        out.push('\n');
        comment(out, &doc_of(key));
        out.push_str(&format!("{key} = {value}\n"));
    }
    // Keys without a default value (optional sections) are named, commented out.
    if let Some(properties) = properties {
        for (key, property) in properties.iter().filter(|(k, _)| !table.contains_key(*k)) {
            out.push('\n');
            comment(out, &description(property, root));
            out.push_str(&format!("# {key}: not set by default\n"));
        }
    }
    for (key, value) in table.iter() {
        let toml::Value::Table(sub) = value else {
            continue;
        };
        let sub_path = if path.is_empty() {
            key.clone()
        } else {
            format!("{path}.{key}")
        };
        let property = properties.and_then(|p| p.get(key)).unwrap_or(&Json::Null);
        out.push('\n');
        comment(out, &description(property, root));
        out.push_str(&format!("[{sub_path}]\n"));
        render_table(out, sub, property, root, &sub_path);
    }
}

/// `node` with references (`$ref`, or the one non-null member of `anyOf`/`allOf`) followed
/// into `root`'s definitions.
fn resolve<'a>(node: &'a Json, root: &'a Json) -> &'a Json {
    if let Some(target) = node.get("$ref").and_then(Json::as_str) {
        let name = target.rsplit('/').next().unwrap_or_default();
        if let Some(def) = root.get("$defs").and_then(|d| d.get(name)) {
            return resolve(def, root);
        }
    }
    for combinator in ["allOf", "anyOf", "oneOf"] {
        if let Some(members) = node.get(combinator).and_then(Json::as_array)
            && let Some(member) = members
                .iter()
                .find(|m| m.get("type").and_then(Json::as_str) != Some("null"))
        {
            return resolve(member, root);
        }
    }
    node
}

/// A property's documentation: its own description, else its type's, with rustdoc links as
/// plain code.
fn description(node: &Json, root: &Json) -> String {
    plain_links(
        node.get("description")
            .or_else(|| resolve(node, root).get("description"))
            .and_then(Json::as_str)
            .unwrap_or_default(),
    )
}

/// Rustdoc's links as plain code: ``[`EngineConfig::x`]`` and ``[`x`](crate::EngineConfig::x)``
/// become `` `x` `` (a key of this file), other ``[`Path`]`` become `` `Path` ``.
fn plain_links(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find("[`") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 2..];
        let Some(end) = after.find("`]") else {
            out.push_str(&rest[start..]);
            return out;
        };
        let name = &after[..end];
        let name = name
            .strip_prefix("EngineConfig::")
            .or_else(|| name.strip_prefix("Self::"))
            .or_else(|| name.strip_prefix("crate::EngineConfig::"))
            .unwrap_or(name);
        out.push('`');
        out.push_str(name);
        out.push('`');
        rest = &after[end + 2..];
        // A link target in parentheses right after the text is dropped.
        if rest.starts_with('(')
            && let Some(close) = rest.find(')')
        {
            rest = &rest[close + 1..];
        }
    }
    out.push_str(rest);
    out
}

/// Writes `text` as `# ` comment lines of at most [`WIDTH`] characters, paragraph by paragraph.
fn comment(out: &mut String, text: &str) {
    for (k, paragraph) in text.split("\n\n").enumerate() {
        if k > 0 {
            out.push_str("#\n");
        }
        let mut line = String::from("#");
        for word in paragraph.split_whitespace() {
            if line.len() + 1 + word.len() > WIDTH && line.len() > 1 {
                out.push_str(&line);
                out.push('\n');
                line = String::from("#");
            }
            line.push(' ');
            line.push_str(word);
        }
        if line.len() > 1 {
            out.push_str(&line);
            out.push('\n');
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_read_back_as_the_default_configuration() {
        let text = defaults_toml().unwrap();
        let config: EngineConfig = toml::from_str(&text).unwrap();
        assert_eq!(config, EngineConfig::default());
    }

    #[test]
    fn every_key_of_the_defaults_is_documented() {
        let text = defaults_toml().unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let mut num_keys = 0;
        for (k, line) in lines.iter().enumerate() {
            let is_key = (line.contains(" = ") && !line.starts_with('#'))
                || line.ends_with(": not set by default");
            let is_table = line.starts_with('[');
            if !(is_key || is_table) {
                continue;
            }
            num_keys += 1;
            let before = k.checked_sub(1).and_then(|p| lines.get(p)).unwrap();
            assert!(before.starts_with("# "), "{line} has no documentation");
        }
        assert!(num_keys > 80, "{num_keys} keys");
    }

    #[test]
    fn rustdoc_links_become_plain_code() {
        assert_eq!(
            plain_links(
                "see [`EngineConfig::hop_s`] and [`x`](crate::EngineConfig::x), [`Fusion`]."
            ),
            "see `hop_s` and `x`, `Fusion`."
        );
        assert_eq!(plain_links("a [`broken"), "a [`broken");
    }

    #[test]
    fn comments_wrap_at_the_width_and_keep_paragraphs() {
        let mut out = String::new();
        let long = "word ".repeat(60);
        comment(&mut out, &format!("{long}\n\nsecond"));
        assert!(out.lines().all(|l| l.len() <= WIDTH && l.starts_with('#')));
        assert!(out.contains("#\n# second\n"));
    }
}
