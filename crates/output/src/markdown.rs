//! Markdown tables as every report writes them: a header row and its `|---|` rule, then one
//! line per row, each cell between `| ` and ` `, the line closed by `|`.
use std::fmt::{Display, Write as _};

/// A table's header row (`| a | b |`) and rule (`|---|---|`), each line ended.
pub fn header(columns: &[&str]) -> String {
    let mut out = String::new();
    let cells: Vec<&dyn Display> = columns.iter().map(|c| c as &dyn Display).collect();
    row(&mut out, &cells);
    out.push('|');
    out.push_str(&"---|".repeat(columns.len()));
    out.push('\n');
    out
}

/// Appends one row of `cells` to `out`: `| a | b |` and a newline.
pub fn row(out: &mut String, cells: &[&dyn Display]) {
    for cell in cells {
        let _ = write!(out, "| {cell} ");
    }
    out.push_str("|\n");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_table_is_its_header_rule_and_rows() {
        let mut md = header(&["a", "b (m)"]);
        row(&mut md, &[&1, &format_args!("{:.2}", 0.5)]);
        assert_eq!(md, "| a | b (m) |\n|---|---|\n| 1 | 0.50 |\n");
    }
}
