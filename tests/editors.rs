//! The TextMate grammar in `editors/textmate/` (syntax highlighting for VS Code, Sublime Text
//! and linguist-style highlighters): it is valid JSON, names every declaration kind
//! `tessera explain` lists and no other, and its patterns, run as an editor runs them (with
//! look-around), find the kinds, comments, numbers and units of every
//! bundled scene. The VS Code extension in `editors/vscode/` carries a copy of the grammar
//! and starts `tessera lsp`.

mod common;

use fancy_regex::Regex;
use serde_json::Value;

fn grammar() -> Value {
    let text = std::fs::read_to_string(common::repo().join("editors/textmate/tessera.tmLanguage.json")).unwrap();
    serde_json::from_str(&text).expect("the grammar is JSON")
}

fn pattern(g: &Value, name: &str) -> Regex {
    Regex::new(g["repository"][name]["match"].as_str().unwrap()).unwrap()
}

fn kinds() -> Vec<String> {
    let run = common::run_in(&common::repo(), &["explain"]);
    run.ok();
    run.stdout()
        .lines()
        .skip(1)
        .filter_map(|l| l.strip_prefix("  ")?.split_whitespace().next().map(String::from))
        .collect()
}

#[test]
fn the_grammar_names_exactly_the_kinds_tessera_knows() {
    let g = grammar();
    assert_eq!(g["scopeName"], "source.tessera");
    assert_eq!(g["fileTypes"], serde_json::json!(["tess"]));
    let decl = g["repository"]["declaration"]["match"].as_str().unwrap();
    let listed = decl.split_once("^\\s*(").unwrap().1.split_once(")\\b").unwrap().0;
    let mut in_grammar: Vec<&str> = listed.split('|').collect();
    let mut known = kinds();
    assert!(known.len() > 10, "{known:?}");
    in_grammar.sort();
    known.sort();
    assert_eq!(in_grammar, known, "editors/textmate: the kinds of the declaration pattern");
}

#[test]
fn every_declaration_comment_and_number_of_the_bundled_scenes_is_highlighted() {
    let g = grammar();
    let (decl, comment, number) = (pattern(&g, "declaration"), pattern(&g, "comment"), pattern(&g, "number"));
    let kinds = kinds();
    let mut seen = 0;
    for entry in std::fs::read_dir(common::repo().join("scenes")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "tess") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        for (i, line) in text.lines().enumerate() {
            let at = format!("{}:{}: {line}", path.display(), i + 1);
            let trimmed = line.trim_start();
            let word = trimmed.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).next().unwrap_or("");
            if kinds.iter().any(|k| k == word) && trimmed.trim_end().ends_with('{') {
                let c = decl.captures(line).unwrap().unwrap_or_else(|| panic!("no declaration in {at}"));
                assert_eq!(c.get(1).unwrap().as_str(), word, "{at}");
                seen += 1;
            }
            if trimmed.starts_with('#') || trimmed.starts_with("//") {
                let m = comment.find(line).unwrap().expect(&at);
                assert_eq!(m.start(), line.len() - trimmed.len(), "{at}");
            }
        }
        // Every quantity with a unit: its number and its unit.
        for m in Regex::new(r"\b[0-9.]+ ?(px|deg|%)").unwrap().find_iter(&text) {
            let m = m.unwrap();
            let c = number.captures(&text[m.start()..]).unwrap().expect("a number");
            assert!(c.get(2).or(c.get(3)).is_some(), "no unit in {:?} of {}", m.as_str(), path.display());
        }
    }
    assert!(seen > 100, "only {seen} declarations seen");
}

fn vscode(rel: &str) -> String {
    std::fs::read_to_string(common::repo().join("editors/vscode").join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

/// The VS Code extension: its manifest is JSON, contributes the language for `.tess` with the
/// grammar (a copy of `editors/textmate`'s, kept identical) and the language configuration,
/// and its entry point starts `tessera lsp`, a subcommand the binary has.
#[test]
fn the_vscode_extension_starts_the_language_server_with_the_grammar() {
    let manifest: Value = serde_json::from_str(&vscode("package.json")).expect("package.json is JSON");
    let language = &manifest["contributes"]["languages"][0];
    assert_eq!(language["id"], "tessera");
    assert_eq!(language["extensions"], serde_json::json!([".tess"]));
    let config: Value = serde_json::from_str(&vscode(language["configuration"].as_str().unwrap()))
        .expect("language-configuration.json is JSON");
    assert_eq!(config["comments"]["lineComment"], "#");
    let g = &manifest["contributes"]["grammars"][0];
    assert_eq!(g["language"], "tessera");
    assert_eq!(g["scopeName"], grammar()["scopeName"]);
    let copy = vscode(g["path"].as_str().unwrap());
    let original = std::fs::read_to_string(common::repo().join("editors/textmate/tessera.tmLanguage.json")).unwrap();
    assert_eq!(copy, original, "editors/vscode/syntaxes: copy editors/textmate/tessera.tmLanguage.json again");
    assert!(manifest["dependencies"]["vscode-languageclient"].is_string());
    let main = vscode(manifest["main"].as_str().unwrap());
    assert!(main.contains("args: [\"lsp\"]") && main.contains("vscode-languageclient"), "{main}");
    let help = common::run_in(&common::repo(), &["lsp", "--help"]);
    help.ok();
    assert!(help.stdout().contains("language server"), "{}", help.stdout());
}
