//! Sizes on the command line: `5G`, `500MiB`, `1048576`.

/// Bytes from a number with an optional unit (K, M, G, T, alone or followed by `B` or `iB`;
/// each a power of 1024, as `du` and `ls -h` count).
pub fn parse(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let digits = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(digits);
    let value: f64 = num
        .parse()
        .map_err(|_| format!("{s:?} is not a size (a number with an optional unit: 500M, 5G)"))?;
    let shift = match unit.trim().to_ascii_uppercase().as_str() {
        "" | "B" => 0,
        "K" | "KB" | "KIB" => 10,
        "M" | "MB" | "MIB" => 20,
        "G" | "GB" | "GIB" => 30,
        "T" | "TB" | "TIB" => 40,
        other => return Err(format!("unknown size unit {other:?} in {s:?} (K, M, G, T)")),
    };
    let bytes = value * (1u64 << shift) as f64;
    if !bytes.is_finite() || bytes > u64::MAX as f64 {
        return Err(format!("{s:?} is too large"));
    }
    Ok(bytes as u64)
}

#[cfg(test)]
mod tests {
    use super::parse;

    #[test]
    fn sizes_with_and_without_units() {
        assert_eq!(parse("1048576"), Ok(1 << 20));
        assert_eq!(parse("5G"), Ok(5 << 30));
        assert_eq!(parse("5GiB"), Ok(5 << 30));
        assert_eq!(parse("1.5k"), Ok(1536));
        assert_eq!(parse("0"), Ok(0));
        assert!(parse("five").is_err());
        assert!(parse("5X").is_err());
        assert!(parse("").is_err());
    }
}
