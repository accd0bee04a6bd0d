//! Which part of an embarrassingly parallel job a run does (`--shard I/N` of `dataset build` and
//! `tolerance`): item k belongs to shard (k mod N) + 1, so N shards writing into one folder cover every
//! item once, and each shard's items are spread over the whole job.

/// Part `index` (1..=count) of `count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

/// Most shards.
pub const MAX_SHARDS: usize = 10_000;

impl Shard {
    pub const ALL: Shard = Shard { index: 1, count: 1 };

    /// "I/N" with 1 <= I <= N <= MAX_SHARDS; the error says what was expected.
    pub fn parse(text: &str) -> Result<Shard, String> {
        let bad = || format!("{text}: expected I/N with 1 <= I <= N <= {MAX_SHARDS}");
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let (index, count): (usize, usize) = (
            i.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if index == 0 || index > count || count > MAX_SHARDS {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }

    /// Whether item `item` (0-based) is this shard's.
    pub fn owns(&self, item: usize) -> bool {
        item % self.count == self.index - 1
    }

    pub fn is_all(&self) -> bool {
        self.count == 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_cover_every_item_once() {
        let shards: Vec<Shard> = (1..=3)
            .map(|i| Shard::parse(&format!("{i}/3")).unwrap())
            .collect();
        for item in 0..10 {
            assert_eq!(shards.iter().filter(|s| s.owns(item)).count(), 1);
        }
        for bad in ["0/3", "4/3", "1/0", "a/b", "3", "1/10001"] {
            assert!(Shard::parse(bad).unwrap_err().contains("expected I/N"), "{bad}");
        }
    }
}
