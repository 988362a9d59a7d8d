//! docs/CONTRACTS.md's tables of parameters and effects echo the one table in the code
//! (`shared/src/catalogue.rs` and the entries' specs): every parameter's code, name and unit,
//! and every effect's name and `--effect` keys, in order, with nothing missing or extra.

use motor_id_shared::model::effects::Effect;
use motor_id_shared::ParamId;
use std::path::Path;

fn contracts() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/CONTRACTS.md");
    std::fs::read_to_string(path).expect("docs/CONTRACTS.md")
}

/// The cells of each row of the table whose header row starts with `header`.
fn table(text: &str, header: &str) -> Vec<Vec<String>> {
    let mut lines = text.lines().skip_while(|l| !l.starts_with(header));
    assert!(lines.next().is_some(), "no table starting {header:?}");
    lines
        .skip(1) // the |---| line
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            // Split on `|` not escaped as `\|`.
            let cells = l.replace("\\|", "\u{1}");
            cells
                .trim_matches('|')
                .split('|')
                .map(|c| c.trim().replace('\u{1}', "|"))
                .collect()
        })
        .collect()
}

/// A unit as the docs print it, in the code's spelling.
fn unit(doc: &str) -> String {
    match doc {
        "-" => String::new(),
        u => u.replace('²', "^2"),
    }
}

/// The words between backticks in `cell`.
fn quoted(cell: &str) -> Vec<&str> {
    cell.split('`').skip(1).step_by(2).collect()
}

#[test]
fn the_parameter_table_lists_every_parameter_with_its_code_name_and_unit() {
    let rows = table(&contracts(), "| code | name |");
    assert_eq!(rows.len(), ParamId::ALL.len(), "one row per parameter");
    for (row, id) in rows.iter().zip(ParamId::ALL) {
        assert_eq!(row[0], id.index().to_string(), "{row:?}");
        assert_eq!(row[1], format!("`{}`", id.name()), "{row:?}");
        assert_eq!(unit(&row[3]), id.unit(), "{row:?}");
    }
}

#[test]
fn the_effect_table_lists_every_entry_with_its_name_and_keys() {
    let rows = table(&contracts(), "| effect | parameters");
    assert_eq!(rows.len(), Effect::ALL.len(), "one row per entry");
    for (row, effect) in rows.iter().zip(Effect::ALL) {
        assert_eq!(row[0], format!("`{}`", effect.name()), "{row:?}");
        let keys: Vec<&str> = effect.params().iter().map(|p| p.short_key()).collect();
        assert_eq!(quoted(&row[1]), keys, "{row:?}");
    }
}
