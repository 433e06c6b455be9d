//! Text read in blocks of whole lines: the reading thread reads each block (inflated ahead on a
//! thread of its own when gzip'd: `formats::gzip`), scans it for where its lines belong,
//! parses it in pieces and visits the result, one block after the other. The
//! ASCII PLY body and OBJ files are read this way; a format says how a block parses
//! ([`Format`]) and its reader visits the results, so errors come in file order as a
//! line-by-line reader would give them.
//!
//! A block is 1 MiB of whole lines (a longer line grows its block), parsed in pieces of 8192
//! lines; a line of more than 64 MiB is an error (binary data in a text file), not a reason to
//! hold the file in memory. Tokens are separated by any whitespace,
//! Unicode included (a no-break space). Numbers are read in the same pass that finds the end of
//! their token: floats by `fast-float2`'s partial parse (the values `str::parse` gives; it still
//! reads the tokens `fast-float2` refuses), integers digit by digit.
//!
//! The pieces are parsed in order on the reading thread. Parsing them in parallel on the pool
//! was measured side by side (release `kiosk import`, stores identical): 0.95 of the time on the
//! dragon as uncompressed ASCII PLY, 0.97 as OBJ, 1.00 gzip'd (its inflating thread takes the
//! other core) — under the 10 % a speed device must earn (docs/performance.md).

use std::io::BufRead;

/// Bytes read per block (whole lines: a line longer than this grows its block).
const BLOCK: usize = 1 << 20;
/// A longer line is an error (binary data in a text file), not a reason to read the whole file.
pub(crate) const MAX_LINE: usize = 64 << 20;
/// Lines parsed into one output.
pub(crate) const PIECE: usize = 8192;

/// How a format parses a block of whole lines: a cheap sequential scan that says where each
/// line belongs, then the parse proper, both on the reading thread.
pub(crate) trait Format {
    /// Where reading stands between blocks (lines before, the row the next line holds…).
    type At: Copy;
    /// What a block parses into; reused from block to block (fresh pages cost more than the
    /// parse).
    type Out: Default;

    /// Notes in `out` (cleared first) which lines of `block` hold what, reading on from `at`;
    /// returns where reading stands after the block.
    fn scan(&self, block: &[u8], at: Self::At, out: &mut Self::Out) -> Self::At;

    /// Parses the lines [`Format::scan`] noted in `out`.
    fn parse(&self, block: &[u8], out: &mut Self::Out);
}

/// Why reading stopped before the end of the input.
#[derive(Debug)]
pub(crate) enum Stop {
    /// The input failed.
    Io(std::io::Error),
    /// No line end within [`MAX_LINE`] bytes after the last line read.
    Overlong,
}

/// Reads `r` to its end, calling `visit(block, parsed)` for each block in order, and returns
/// where reading stands after the last. When reading fails, the lines read before are visited
/// first and `stop` decides, given where reading stands: an error, or `Ok` where the format
/// accepts that the input ends there (e.g. junk after the last PLY element).
pub(crate) fn read<F: Format, E>(
    r: &mut (impl BufRead + ?Sized),
    format: &F,
    mut at: F::At,
    mut visit: impl FnMut(&[u8], &mut F::Out) -> Result<(), E>,
    mut stop: impl FnMut(Stop, F::At) -> Result<F::At, E>,
) -> Result<F::At, E> {
    let mut source = Source { carry: Vec::new(), failed: None };
    // The block's buffer and what it parses into are used again for the next block.
    let (mut bytes, mut out) = (Vec::new(), F::Out::default());
    loop {
        bytes = match source.next_block(r, bytes) {
            Ok(Some(bytes)) => bytes,
            Ok(None) => return Ok(at),
            Err(e) => return stop(e, at),
        };
        at = format.scan(&bytes, at, &mut out);
        format.parse(&bytes, &mut out);
        visit(&bytes, &mut out)?;
    }
}

/// The input, read in blocks of whole lines.
struct Source {
    /// The bytes after the last line end of the block before.
    carry: Vec<u8>,
    /// A failure that comes after the lines read before it.
    failed: Option<Stop>,
}

impl Source {
    /// Reads the next block of whole lines into `buf`, or `None` at the end of the input.
    fn next_block(
        &mut self,
        r: &mut (impl BufRead + ?Sized),
        mut buf: Vec<u8>,
    ) -> Result<Option<Vec<u8>>, Stop> {
        if let Some(e) = self.failed.take() {
            return Err(e);
        }
        buf.clear();
        buf.append(&mut self.carry);
        let mut searched = 0;
        loop {
            let old = buf.len();
            let want = BLOCK.max(old);
            buf.resize(old + want, 0);
            let (got, failed) = crate::fill(r, &mut buf[old..]);
            buf.truncate(old + got);
            if let Some(e) = failed {
                // The whole lines before the failure are read first (a line-by-line reader would
                // have parsed them); the failure comes after them.
                return match memchr::memrchr(b'\n', &buf) {
                    Some(last) => {
                        buf.truncate(last + 1);
                        self.failed = Some(Stop::Io(e));
                        Ok(Some(buf))
                    }
                    None => Err(Stop::Io(e)),
                };
            }
            let end = got < want;
            if let Some(last) = memchr::memrchr(b'\n', &buf[searched..]) {
                if !end {
                    self.carry.extend_from_slice(&buf[searched + last + 1..]);
                    buf.truncate(searched + last + 1);
                }
                // At the end of the input, the bytes after the last line end are the last line.
                return Ok(Some(buf));
            }
            if buf.len() > MAX_LINE {
                return Err(Stop::Overlong);
            }
            if end {
                return Ok((!buf.is_empty()).then_some(buf));
            }
            searched = buf.len();
        }
    }
}

/// The lines of a block as (start, end) byte ranges, without their line ends.
pub(crate) fn lines(block: &[u8]) -> impl Iterator<Item = (usize, usize)> + '_ {
    let last = (block.last().is_some_and(|&b| b != b'\n')).then_some(block.len());
    let mut start = 0;
    memchr::memchr_iter(b'\n', block).chain(last).map(move |end| {
        let line = (start, end);
        start = end + 1;
        line
    })
}

/// Whitespace as `str::split_whitespace` sees it, in the ASCII range (tab to carriage return,
/// space).
pub(crate) fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t'..=b'\r')
}

/// Whether a line holds nothing but whitespace (Unicode whitespace too, in UTF-8 text).
pub(crate) fn is_blank(line: &[u8]) -> bool {
    // Decided at the first byte that is not ASCII whitespace (the first of most lines): any other
    // ASCII character is not whitespace; a non-ASCII one may be, and the line is checked as text.
    match line.iter().position(|&b| !is_space(b)) {
        None => true,
        Some(i) if line[i].is_ascii() => false,
        Some(i) => std::str::from_utf8(&line[i..]).is_ok_and(|s| s.trim().is_empty()),
    }
}

/// Parses `lines` in pieces of [`PIECE`], in order, one output per piece (`pieces` is resized
/// to their number; each output is reused from block to block, and `parse` clears it); `parse`
/// is given the piece's index, its lines and its output.
pub(crate) fn in_pieces<L, P: Default>(
    lines: &[L],
    pieces: &mut Vec<P>,
    mut parse: impl FnMut(usize, &[L], &mut P),
) {
    pieces.resize_with(lines.len().div_ceil(PIECE), P::default);
    lines.chunks(PIECE).zip(pieces.iter_mut()).enumerate().for_each(|(k, (ls, p))| parse(k, ls, p));
}

/// Whitespace-separated tokens of a line: split by hand on ASCII whitespace, or as
/// `str::split_whitespace` splits them where the line has other characters (a no-break space
/// between values, say).
pub(crate) enum Tokens<'a> {
    Ascii(&'a [u8]),
    Unicode(std::str::SplitWhitespace<'a>),
}

impl<'a> Tokens<'a> {
    pub(crate) fn new(line: &'a [u8]) -> Self {
        if line.is_ascii() {
            return Self::Ascii(line);
        }
        match std::str::from_utf8(line) {
            Ok(text) => Self::Unicode(text.split_whitespace()),
            Err(_) => Self::Ascii(line),
        }
    }
}

impl<'a> Iterator for Tokens<'a> {
    type Item = &'a [u8];

    fn next(&mut self) -> Option<&'a [u8]> {
        let b = match self {
            Self::Ascii(rest) => *rest,
            Self::Unicode(words) => return words.next().map(str::as_bytes),
        };
        let start = skip(b, 0, true);
        if start == b.len() {
            *self = Self::Ascii(&[]);
            return None;
        }
        let end = skip(b, start, false);
        *self = Self::Ascii(&b[end..]);
        Some(&b[start..end])
    }
}

/// The first index at or after `i` whose byte is not ASCII whitespace (`space`), or is (not
/// `space`); the length if there is none.
#[inline]
pub(crate) fn skip(b: &[u8], mut i: usize, space: bool) -> usize {
    while i < b.len() && is_space(b[i]) == space {
        i += 1;
    }
    i
}

impl<'a> Tokens<'a> {
    /// The next token as `parse` reads it, or as `Err(token)` when `parse` refuses it; `None` at
    /// the end of the line. Where the line is ASCII, `plain` reads the number at the start of
    /// the rest of the line in the same pass that finds the token's end: its value and length,
    /// taken when whitespace or the end of the line follows (the whole token); otherwise, the
    /// token is parsed whole.
    #[inline(always)]
    fn next_number<T>(
        &mut self,
        parse: fn(&[u8]) -> Option<T>,
        plain: impl FnOnce(&'a [u8]) -> Option<(T, usize)>,
    ) -> Option<Result<T, &'a [u8]>> {
        if let Self::Ascii(b) = *self {
            let start = skip(b, 0, true);
            if start < b.len()
                && let Some((v, n)) = plain(&b[start..])
                && (start + n == b.len() || is_space(b[start + n]))
            {
                *self = Self::Ascii(&b[start + n..]);
                return Some(Ok(v));
            }
        }
        self.next().map(|t| parse(t).ok_or(t))
    }

    /// The next token as the integer [`parse_i64`] reads from it (a plain one, optional sign and
    /// at most 18 digits, read in the same pass that finds its end), or as `Err(token)` when it
    /// is not an integer. `None` at the end of the line.
    #[inline(always)]
    pub(crate) fn next_int(&mut self) -> Option<Result<i64, &'a [u8]>> {
        self.next_number(parse_i64, plain_int)
    }

    /// The next token as the `f64` [`parse_f64`] reads from it, or `Err(token)` when it is not a
    /// number. `None` at the end of the line. `fast-float2` reads the longest number at the
    /// start of the rest of the line, which is the token when whitespace or the end follows it.
    #[inline]
    pub(crate) fn next_f64(&mut self) -> Option<Result<f64, &'a [u8]>> {
        self.next_number(parse_f64, |b| fast_float2::parse_partial::<f64, _>(b).ok())
    }
}

/// The plain integer `b` starts with (optional sign, at most 18 digits: no overflow) and its
/// length in bytes, read in one pass, digit by digit; `None` when `b` starts with no digit after
/// its sign. Whether the token ends there is the caller's to check.
#[inline(always)]
pub(crate) fn plain_int(b: &[u8]) -> Option<(i64, usize)> {
    let negative = b.first() == Some(&b'-');
    let digits = usize::from(matches!(b.first(), Some(b'-' | b'+')));
    let mut i = digits;
    let mut v = 0i64;
    // At most 18 digits (no overflow); a longer run is no plain integer.
    let most = b.len().min(digits + 18);
    while i < most {
        let d = b[i].wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        v = v * 10 + i64::from(d);
        i += 1;
    }
    (i > digits).then_some((if negative { -v } else { v }, i))
}

/// An `f64` as `str::parse` reads it (`nan` and `inf` included), by `fast-float2` straight from
/// the bytes (no UTF-8 check; the same correctly rounded value), or by `str::parse` for a token
/// it refuses, so that exactly the tokens `str::parse` takes are taken.
pub(crate) fn parse_f64(t: &[u8]) -> Option<f64> {
    fast_float2::parse(t).ok().or_else(|| std::str::from_utf8(t).ok()?.parse().ok())
}

/// An `i64` as `str::parse` reads it (optional sign, decimal digits), without its UTF-8 check
/// for the short tokens that make up most text bodies.
pub(crate) fn parse_i64(t: &[u8]) -> Option<i64> {
    let digits = match t.first()? {
        b'-' | b'+' => &t[1..],
        _ => t,
    };
    if digits.is_empty() || digits.len() > 18 {
        return std::str::from_utf8(t).ok()?.parse().ok();
    }
    let mut v = 0i64;
    for &d in digits {
        let d = d.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v * 10 + i64::from(d);
    }
    Some(if t[0] == b'-' { -v } else { v })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integers_parse_as_str_parse_does() {
        for t in [
            "0",
            "-0",
            "+7",
            "-128",
            "255",
            "123456789012345678",
            "9223372036854775807",
            "-9223372036854775808",
        ] {
            assert_eq!(parse_i64(t.as_bytes()), t.parse().ok(), "{t}");
        }
        for t in ["", "-", "+", "1.0", "1e3", "12a", "9223372036854775808", " 1", "--1"] {
            assert_eq!(parse_i64(t.as_bytes()), None, "{t:?}");
        }
    }

    #[test]
    fn floats_parse_as_str_parse_does() {
        let same = |t: &str| {
            let want: Option<f64> = t.parse().ok();
            let got = parse_f64(t.as_bytes());
            assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{t:?}");
        };
        for t in [
            "0",
            "-0",
            "+1.5",
            "1.",
            ".5",
            "1e5",
            "1E-5",
            "1e+5",
            "-0.0378297",
            "3.4028235e38",
            "1e400",
            "-1e400",
            "1e-400",
            "4.9e-324",
            "2.2250738585072011e-308",
            "9007199254740993",
            "0.1000000000000000055511151231257827",
            "123456789012345678901234567890",
            "00012",
            "nan",
            "NaN",
            "-nan",
            "+nan",
            "inf",
            "-inf",
            "+infinity",
            "Infinity",
            "INF",
            "infin",
            "1e",
            "e5",
            ".",
            "-",
            "+",
            "",
            "1.2.3",
            "0x10",
            "1_000",
            "1,5",
            " 1",
            "1 ",
            "1.5f",
            "--1",
            "١",
        ] {
            same(t);
        }
        let mut rng = rand_pcg::Pcg64::new(7, 11);
        for _ in 0..20_000 {
            use rand::Rng;
            let v = f64::from_bits(rng.random());
            let short = f64::from(v as f32);
            for t in [format!("{v}"), format!("{v:e}"), format!("{short}"), format!("{:.6}", short)] {
                same(&t);
            }
        }
    }

    #[test]
    fn integer_tokens_read_in_one_pass_match_the_tokens_and_their_parse() {
        // Runs of 0 to 20 digits, with signs, leading zeros and other bytes after them (bytes
        // that are no UTF-8 too: such a line is split as ASCII).
        const AFTER: &[u8] = b" \t/.a:\x7f\x80\xb9\xba\xff9 ";
        let mut rng = rand_pcg::Pcg64::new(5, 9);
        let mut random: Vec<Vec<u8>> = Vec::new();
        for _ in 0..3000 {
            use rand::Rng;
            let mut line = Vec::new();
            for _ in 0..rng.random_range(1..8) {
                match rng.random_range(0..10) {
                    0 => line.push(b'-'),
                    1 => line.push(b'+'),
                    2 => line.push(b'0'),
                    _ => {}
                }
                for _ in 0..rng.random_range(0..21) {
                    line.push(b'0' + rng.random_range(0..10u8));
                }
                line.push(AFTER[rng.random_range(0..AFTER.len())]);
            }
            random.push(line);
        }
        for line in [
            "3 12 345 6789",
            "  -7\t+8 -0 0 ",
            "1.5 2e3 x -- - + 12a 7",
            "123456789012345678 1234567890123456789 00000000000000000000042 -99999999999999999999",
            "1\u{a0}2 3",
            "",
            "   ",
            "1234567 12345678 123456789 7654321x 0000001 99999999",
            "/0 :9 9: 8\x7f",
        ]
        .into_iter()
        .map(str::as_bytes)
        .chain(random.iter().map(Vec::as_slice))
        {
            let want: Vec<Result<i64, &[u8]>> = Tokens::new(line).map(|t| parse_i64(t).ok_or(t)).collect();
            let mut tok = Tokens::new(line);
            let got: Vec<Result<i64, &[u8]>> = std::iter::from_fn(|| tok.next_int()).collect();
            // The same tokens, and the same integers wherever the integer is taken.
            assert_eq!(got.len(), want.len(), "{line:?}");
            for (g, w) in got.iter().zip(&want) {
                match (g, w) {
                    (Ok(a), Ok(b)) => assert_eq!(a, b, "{line:?}"),
                    (Err(t), Ok(b)) => {
                        assert_eq!(parse_i64(t), Some(*b), "{line:?}: the caller parses {t:?}")
                    }
                    (Err(a), Err(b)) => assert_eq!(a, b, "{line:?}"),
                    (Ok(a), Err(b)) => panic!("{line:?}: {a} taken from {b:?}"),
                }
            }
        }
    }

    #[test]
    fn float_tokens_read_in_one_pass_match_the_tokens_and_their_parse() {
        let mut lines = vec![
            "1.5 -2e3 +.5 7. 1e 1e+ 0x10 nan -inf infinity infx 1.5.2 1,5 -- - + . e5 3".to_string(),
            "  -0.0378297\t0.127423 -0.00326827\r".to_string(),
            "1e400 -1e-400 4.9e-324 123456789012345678901234567890 00012 1_000".to_string(),
            "1\u{a0}2.5 3".to_string(),
            String::new(),
            "   ".to_string(),
        ];
        let mut rng = rand_pcg::Pcg64::new(3, 5);
        for _ in 0..2000 {
            use rand::Rng;
            let v = f64::from_bits(rng.random());
            let short = f64::from(v as f32);
            lines.push(format!("{v} {v:e} {short} {short:.6}x {:.6} {v}", short));
        }
        for line in &lines {
            let want: Vec<Result<u64, &[u8]>> =
                Tokens::new(line.as_bytes()).map(|t| parse_f64(t).map(f64::to_bits).ok_or(t)).collect();
            let mut tok = Tokens::new(line.as_bytes());
            let got: Vec<Result<u64, &[u8]>> =
                std::iter::from_fn(|| tok.next_f64()).map(|r| r.map(f64::to_bits)).collect();
            assert_eq!(got, want, "{line:?}");
        }
    }

    #[test]
    fn tokens_split_on_ascii_whitespace() {
        let toks: Vec<&[u8]> = Tokens::new(b"  1 2\t3\r\n").collect();
        assert_eq!(toks, [b"1", b"2", b"3"]);
        assert_eq!(Tokens::new(b" \t\r").next(), None);
        let nbsp: Vec<&[u8]> = Tokens::new("1\u{a0}2\u{3000}3".as_bytes()).collect();
        assert_eq!(nbsp, [b"1", b"2", b"3"]);
        assert!(is_blank("\u{a0} \t".as_bytes()) && !is_blank(b" x") && !is_blank(b"\xff"));
    }

    #[test]
    fn lines_of_a_block_with_and_without_a_last_line_end() {
        let of = |b: &[u8]| lines(b).map(|(s, e)| b[s..e].to_vec()).collect::<Vec<_>>();
        assert_eq!(of(b"a\nbc\n"), [b"a".to_vec(), b"bc".to_vec()]);
        assert_eq!(of(b"a\n\nbc"), [b"a".to_vec(), b"".to_vec(), b"bc".to_vec()]);
        assert!(of(b"").is_empty());
    }
}
