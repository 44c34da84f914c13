//! The papers' published figures, transcribed into `data/published/` (one CSV file per
//! table, its source cited in the file's `#` lines) and compiled in, so that a report sets
//! them beside today's without the papers at hand.

/// One transcribed table: its file name, for the reports to cite, and its rows.
pub(super) struct Table {
    pub file: &'static str,
    headers: Vec<String>,
    rows: Vec<Vec<String>>,
}

/// Every transcribed table, by file name.
const FILES: &[(&str, &str)] = &[
    (
        "scg97-figs12-14-17-levels.csv",
        include_str!("../../data/published/scg97-figs12-14-17-levels.csv"),
    ),
    (
        "scg97-figs12-14-17-totals.csv",
        include_str!("../../data/published/scg97-figs12-14-17-totals.csv"),
    ),
    (
        "scg97-figs20-23-rendering.csv",
        include_str!("../../data/published/scg97-figs20-23-rendering.csv"),
    ),
    (
        "scg97-figs20-23-times.csv",
        include_str!("../../data/published/scg97-figs20-23-times.csv"),
    ),
    (
        "havran97-table7.csv",
        include_str!("../../data/published/havran97-table7.csv"),
    ),
    (
        "havran97-table8.csv",
        include_str!("../../data/published/havran97-table8.csv"),
    ),
    (
        "scg97-fig4-scenes.csv",
        include_str!("../../data/published/scg97-fig4-scenes.csv"),
    ),
    (
        "rtnews-table.csv",
        include_str!("../../data/published/rtnews-table.csv"),
    ),
    (
        "eg95-section3.2-claims.csv",
        include_str!("../../data/published/eg95-section3.2-claims.csv"),
    ),
    (
        "havran97-table4.csv",
        include_str!("../../data/published/havran97-table4.csv"),
    ),
    (
        "havran97-tables5-6.csv",
        include_str!("../../data/published/havran97-tables5-6.csv"),
    ),
];

impl Table {
    /// The table transcribed in `file` (one of [`FILES`]); the files are the repository's
    /// own and tested to parse, so a failure here is a defect, not an input error.
    pub fn load(file: &'static str) -> Table {
        let (_, text) = FILES
            .iter()
            .find(|(f, _)| *f == file)
            .unwrap_or_else(|| panic!("{file}: not a transcribed table"));
        let mut reader = csv::ReaderBuilder::new()
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        let headers = reader
            .headers()
            .expect("a header line")
            .iter()
            .map(str::to_string)
            .collect();
        let rows = reader
            .records()
            .map(|r| r.expect("a CSV row").iter().map(str::to_string).collect())
            .collect();
        Table {
            file,
            headers,
            rows,
        }
    }

    pub fn rows(&self) -> impl Iterator<Item = Row<'_>> {
        self.rows.iter().map(move |r| Row {
            table: self,
            row: r,
        })
    }

    /// The rows whose column `column` reads `value`.
    pub fn rows_where(&self, column: &str, value: &str) -> std::vec::IntoIter<Row<'_>> {
        self.rows()
            .filter(|r| r.text(column) == value)
            .collect::<Vec<_>>()
            .into_iter()
    }
}

/// One row of a [`Table`], read by column name.
#[derive(Clone, Copy)]
pub(super) struct Row<'a> {
    table: &'a Table,
    row: &'a [String],
}

impl<'a> Row<'a> {
    pub fn text(&self, column: &str) -> &'a str {
        let k = self
            .table
            .headers
            .iter()
            .position(|h| h == column)
            .unwrap_or_else(|| panic!("{}: no column {column}", self.table.file));
        &self.row[k]
    }

    pub fn number(&self, column: &str) -> f64 {
        let t = self.text(column);
        t.parse()
            .unwrap_or_else(|_| panic!("{}: {column} = '{t}' is not a number", self.table.file))
    }
}

#[cfg(test)]
mod tests {
    use super::{FILES, Table};

    /// Every file parses, with as many fields a row as headers and every field after the
    /// first text column a number where the header says it is one.
    #[test]
    fn every_transcribed_table_parses() {
        for (file, _) in FILES {
            let t = Table::load(file);
            assert!(t.rows().count() > 0, "{file}: no rows");
            for r in &t.rows {
                assert_eq!(r.len(), t.headers.len(), "{file}: {r:?}");
            }
            for row in t.rows() {
                for h in &t.headers {
                    let text = row.text(h);
                    if h.ends_with("percent") || h.starts_with("method") || h.starts_with("pct_") {
                        assert!(text.parse::<f64>().is_ok(), "{file}: {h} = {text}");
                    }
                }
            }
        }
    }
}
