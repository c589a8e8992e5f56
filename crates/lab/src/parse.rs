//! Parsers for argument values that several subcommands share.

/// `WIDTHxHEIGHT` (either case of `x`), both at least 1.
pub fn size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}': expected WIDTHxHEIGHT, e.g. 320x240"))?;
    let parse = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!(
            "'{s}': expected WIDTHxHEIGHT with whole numbers of at least 1"
        )),
    };
    Ok((parse(w)?, parse(h)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_zero_is_refused() {
        assert_eq!(size("320x240"), Ok((320, 240)));
        assert_eq!(size("16X9"), Ok((16, 9)));
        assert!(size("0x10").is_err());
        assert!(size("320").is_err());
        assert!(size("ax3").is_err());
    }
}
