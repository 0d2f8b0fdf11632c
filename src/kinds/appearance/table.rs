//! Cluster tables: which unified texture each region of a dressed structure takes, as the
//! JSON file a `view = cluster_table` output writes and `keep_clusters` reads back for
//! `cluster_choice = sticky` ([references: frasson §4.1.3]).
//!
//! ```json
//! {
//!   "clusters": 3,
//!   "regions": {
//!     "0": 2,
//!     "1": 0
//!   }
//! }
//! ```
//!
//! `regions` maps a region id of the dressed structure (its index, as the `labels16` view of a
//! structure numbers it) to a cluster `0 … clusters − 1`; regions without an entry take their
//! closest shape's cluster. `clusters` records how many clusters the appearance had when the
//! table was written; it may be left out of a table written by hand.

use std::collections::BTreeMap;

/// A cluster table as read: the recorded cluster count and region id → cluster.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ClusterTable {
    pub clusters: Option<usize>,
    pub regions: BTreeMap<usize, usize>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct TableFile {
    #[serde(default)]
    clusters: Option<usize>,
    regions: BTreeMap<String, usize>,
}

/// The table of a dressing's clusters (`None`: the region is not dressed and left out), with
/// the appearance's cluster count; regions in increasing id order, one per line.
pub fn write(clusters: &[Option<usize>], count: usize) -> String {
    let entries: Vec<String> =
        clusters.iter().enumerate().filter_map(|(r, c)| c.map(|c| format!("    \"{r}\": {c}"))).collect();
    if entries.is_empty() {
        return format!("{{\n  \"clusters\": {count},\n  \"regions\": {{}}\n}}\n");
    }
    format!("{{\n  \"clusters\": {count},\n  \"regions\": {{\n{}\n  }}\n}}\n", entries.join(",\n"))
}

/// Parses a table; the error says what is wrong in words.
pub fn parse(bytes: &[u8]) -> Result<ClusterTable, String> {
    let file: TableFile = serde_json::from_slice(bytes).map_err(|e| e.to_string())?;
    let mut regions = BTreeMap::new();
    for (key, cluster) in file.regions {
        let id: usize = key
            .parse()
            .ok()
            .filter(|id: &usize| id.to_string() == key)
            .ok_or_else(|| format!("`{key}` is not a region id (a whole number written without leading zeros)"))?;
        regions.insert(id, cluster);
    }
    Ok(ClusterTable { clusters: file.clusters, regions })
}

/// Why a table does not fit the appearance it is used with.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Mismatch {
    /// The table was written for another number of clusters.
    Count { table: usize, appearance: usize },
    /// A region is given a cluster the appearance does not have (the first such, by id).
    Cluster { region: usize, cluster: usize, appearance: usize },
}

impl std::fmt::Display for Mismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Mismatch::Count { table, appearance } => {
                write!(f, "the table was written for {table} clusters, but this appearance has {appearance}")
            }
            Mismatch::Cluster { region, cluster, appearance } => write!(
                f,
                "the table gives region {region} cluster {cluster}, but this appearance has {appearance} clusters (0 to {})",
                appearance.saturating_sub(1)
            ),
        }
    }
}

/// Each of `regions` regions' kept cluster, checked against the appearance's `clusters`,
/// and the number of table entries naming a region past the last.
pub fn previous_clusters(
    table: &ClusterTable,
    regions: usize,
    clusters: usize,
) -> Result<(Vec<Option<usize>>, usize), Mismatch> {
    if let Some(table) = table.clusters.filter(|&k| k != clusters) {
        return Err(Mismatch::Count { table, appearance: clusters });
    }
    if let Some((&region, &cluster)) = table.regions.iter().find(|(_, &c)| c >= clusters) {
        return Err(Mismatch::Cluster { region, cluster, appearance: clusters });
    }
    let mut out = vec![None; regions];
    let mut beyond = 0;
    for (&r, &c) in &table.regions {
        match out.get_mut(r) {
            Some(slot) => *slot = Some(c),
            None => beyond += 1,
        }
    }
    Ok((out, beyond))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_table_reads_back() {
        let clusters = [Some(2), None, Some(0), Some(1), None, None, None, None, None, None, Some(2)];
        let text = write(&clusters, 3);
        assert!(text.contains("\"10\": 2") && text.find("\"2\": 0") < text.find("\"10\": 2"), "{text}");
        let t = parse(text.as_bytes()).expect("parses");
        assert_eq!(t.clusters, Some(3));
        let (prev, beyond) = previous_clusters(&t, clusters.len(), 3).expect("fits");
        assert_eq!(prev, clusters);
        assert_eq!(beyond, 0);
        let empty = write(&[None, None], 2);
        assert_eq!(parse(empty.as_bytes()).expect("parses").regions.len(), 0);
    }

    #[test]
    fn tables_that_do_not_fit_are_refused() {
        let t = parse(br#"{ "regions": { "0": 1, "4": 3, "9": 0 } }"#).expect("parses");
        assert_eq!(t.clusters, None);
        assert_eq!(previous_clusters(&t, 8, 4), Ok((vec![Some(1), None, None, None, Some(3), None, None, None], 1)));
        assert_eq!(previous_clusters(&t, 8, 3), Err(Mismatch::Cluster { region: 4, cluster: 3, appearance: 3 }));
        let t = parse(br#"{ "clusters": 5, "regions": { "0": 1 } }"#).expect("parses");
        assert_eq!(previous_clusters(&t, 8, 4), Err(Mismatch::Count { table: 5, appearance: 4 }));
        for bad in [
            &br#"{ "regions": { "01": 1 } }"#[..],
            br#"{ "regions": { "a": 1 } }"#,
            br#"{ "regions": { "1": -1 } }"#,
            br#"{ "regions": [1, 2] }"#,
            br#"{ "clusters": 2 }"#,
            br#"{ "regions": {}, "extra": 1 }"#,
            b"not json",
        ] {
            assert!(parse(bad).is_err(), "{}", String::from_utf8_lossy(bad));
        }
    }
}
