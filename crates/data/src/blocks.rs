//! Splits of a single recording into blocks of consecutive frames.
//!
//! Neighbouring frames of a video are near-duplicates, so a test frame picked at random among
//! training frames measures memory, not localization. A [`BlockSplit`] cuts each sequence into
//! blocks of `block` consecutive frames and holds out every `every`-th block for testing
//! (`offset` picks which of each group of `every`, from 0). Validation blocks come out of the
//! remaining training blocks by the same rule, so a recipe is chosen on frames as far from
//! training as the test frames are (only a block's two ends touch a training frame).
//!
//! Written `BLOCK:EVERY[:OFFSET]` on the command line (`100:5` = blocks of 100 frames, the last
//! of every five held out: frames 400–499 and 900–999 of a 1000-frame recording, the protocol of
//! `../shared/data/7scenes_redkitchen_seq01`'s README).

use crate::native::SplitName;
use std::fmt;
use std::str::FromStr;

/// A reproducible split of each sequence into blocks of consecutive frames (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct BlockSplit {
    /// Frames per block (≥ 1).
    pub block: usize,
    /// One block of every `every` is held out (≥ 2).
    pub every: usize,
    /// Which block of each group of `every` is held out, from 0 (< `every`).
    pub offset: usize,
}

impl Default for BlockSplit {
    /// Blocks of 100 frames, the last of every five held out (the redkitchen README's protocol).
    fn default() -> Self {
        BlockSplit {
            block: 100,
            every: 5,
            offset: 4,
        }
    }
}

impl BlockSplit {
    /// A split, checked: `block ≥ 1`, `every ≥ 2`, `offset < every`.
    pub fn new(block: usize, every: usize, offset: usize) -> Result<Self, String> {
        if block == 0 {
            return Err("a block holds at least one frame".into());
        }
        if every < 2 {
            return Err("every must be at least 2 (every = 1 would hold out everything)".into());
        }
        if offset >= every {
            return Err(format!(
                "offset {offset} is not below every ({every}): it picks one block of each group"
            ));
        }
        Ok(BlockSplit {
            block,
            every,
            offset,
        })
    }

    /// The part of the `index`-th frame (from 0) of a sequence: test when its block is held out;
    /// among the training blocks (counted from 0), those the same rule holds out are validation.
    pub fn part(&self, index: usize) -> SplitName {
        let b = index / self.block;
        if b % self.every == self.offset {
            return SplitName::Test;
        }
        // Training blocks before this one: every group of `every` blocks has `every - 1`.
        let groups = b / self.every;
        let within = b % self.every;
        let train_index = groups * (self.every - 1) + within - usize::from(within > self.offset);
        if train_index % self.every == self.offset {
            SplitName::Val
        } else {
            SplitName::Train
        }
    }

    /// Validation only: the part of a frame of a sequence that is all training (a dataset's own
    /// split gave it to training); the held-out blocks of the rule become validation.
    pub fn part_of_training(&self, index: usize) -> SplitName {
        if (index / self.block) % self.every == self.offset {
            SplitName::Val
        } else {
            SplitName::Train
        }
    }
}

impl fmt::Display for BlockSplit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.block, self.every, self.offset)
    }
}

impl FromStr for BlockSplit {
    type Err = String;

    /// `BLOCK:EVERY[:OFFSET]`; the offset defaults to `EVERY - 1` (the last block of each group).
    fn from_str(s: &str) -> Result<Self, String> {
        let usage = || format!("'{s}': expected BLOCK:EVERY[:OFFSET], e.g. 100:5 or 40:4:3");
        let numbers = s
            .split(':')
            .map(|p| p.trim().parse::<usize>().map_err(|_| usage()))
            .collect::<Result<Vec<_>, _>>()?;
        match numbers[..] {
            [block, every] => BlockSplit::new(block, every, every.saturating_sub(1)),
            [block, every, offset] => BlockSplit::new(block, every, offset),
            _ => Err(usage()),
        }
        .map_err(|e| format!("'{s}': {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn parts(split: BlockSplit, n: usize) -> Vec<SplitName> {
        (0..n).map(|i| split.part(i)).collect()
    }

    #[test]
    fn the_readme_protocol_holds_out_400_to_499_and_900_to_999() {
        let split: BlockSplit = "100:5".parse().unwrap();
        assert_eq!(split, BlockSplit::default());
        let p = parts(split, 1000);
        let test: Vec<usize> = (0..1000).filter(|&i| p[i] == SplitName::Test).collect();
        assert_eq!(test, (400..500).chain(900..1000).collect::<Vec<_>>());
        // Training blocks 0-3, 5-8: the fifth of them (frames 500-599) validates.
        let val: Vec<usize> = (0..1000).filter(|&i| p[i] == SplitName::Val).collect();
        assert_eq!(val, (500..600).collect::<Vec<_>>());
        assert_eq!(p.iter().filter(|&&x| x == SplitName::Train).count(), 700);
    }

    #[test]
    fn short_blocks_hold_out_every_fourth() {
        let split: BlockSplit = "40:4".parse().unwrap();
        let p = parts(split, 1000);
        let count = |w| p.iter().filter(|&&x| x == w).count();
        assert_eq!(count(SplitName::Test), 240);
        assert_eq!(count(SplitName::Val), 160);
        assert_eq!(count(SplitName::Train), 600);
        assert_eq!(p[120], SplitName::Test);
        assert_eq!(p[119], SplitName::Train);
    }

    #[test]
    fn bad_specs_are_refused_with_the_reason() {
        for (s, want) in [
            ("0:5", "at least one frame"),
            ("100:1", "at least 2"),
            ("100:5:5", "not below"),
            ("100", "BLOCK:EVERY"),
            ("a:b", "BLOCK:EVERY"),
            ("1:2:3:4", "BLOCK:EVERY"),
        ] {
            let e = s.parse::<BlockSplit>().unwrap_err();
            assert!(e.contains(want) && e.contains(s), "{s}: {e}");
        }
        assert_eq!(
            "40:4:1".parse::<BlockSplit>().unwrap().to_string(),
            "40:4:1"
        );
    }

    proptest! {
        #[test]
        fn every_block_is_whole_and_each_part_is_used(block in 1usize..50, every in 2usize..7,
                                                      offset in 0usize..7, n in 0usize..3000) {
            prop_assume!(offset < every);
            let split = BlockSplit::new(block, every, offset).unwrap();
            let p = parts(split, n);
            for i in 1..n {
                if i % block != 0 {
                    prop_assert_eq!(p[i], p[i - 1]);
                }
            }
            if n >= block * every * every {
                for want in [SplitName::Train, SplitName::Val, SplitName::Test] {
                    prop_assert!(p.contains(&want));
                }
            }
        }
    }
}
