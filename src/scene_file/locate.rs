//! Finds where a field of a scene file is written, so that checks made after the file was read
//! (time-step bounds, particle counts, mesh files, ...) report the line and column of the field
//! at fault, as the reader's own errors do.
//!
//! A small scanner over RON's syntax (comments, strings, raw strings, brackets), enough for
//! text that has already been parsed: a path such as `fluids[0].blocks[1].size` is followed
//! from the top-level value, through fields (`name: value`), list items (`[i]`), enum variants
//! (`Collider` in `region.Collider.name`) and `Some(..)` wrappers. When a segment is not in
//! the text (a field left to its default), the deepest one found is returned.

/// A token: its kind and where it starts (byte offset).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Open(u8),
    Close,
    Comma,
    Colon,
    /// An identifier, number or keyword.
    Word,
    /// A string or character literal.
    Literal,
}

#[derive(Clone, Copy, Debug)]
struct Token {
    kind: Kind,
    start: usize,
    end: usize,
}

/// At a raw or byte string's start (`r"`, `r#"`, `b"`, `br#"`): the index of its opening
/// quote, its number of `#` and whether it is raw (no escapes).
fn raw_string_start(b: &[u8], i: usize) -> Option<(usize, usize, bool)> {
    let (mut j, raw) = match (b[i], b.get(i + 1)) {
        (b'r', _) => (i + 1, true),
        (b'b', Some(b'r')) => (i + 2, true),
        (b'b', Some(b'"')) => (i + 1, false),
        _ => return None,
    };
    let hashes_start = j;
    while raw && j < b.len() && b[j] == b'#' {
        j += 1;
    }
    (b.get(j) == Some(&b'"')).then_some((j, j - hashes_start, raw))
}

/// Splits a RON text into the tokens [`locate`](self) walks: brackets, commas, colons, words
/// and literals; whitespace and comments are skipped.
fn tokens(text: &str) -> Vec<Token> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_whitespace() {
            i += 1;
        } else if b[i..].starts_with(b"//") {
            i = line_comment_end(b, i);
        } else if b[i..].starts_with(b"/*") {
            i = block_comment_end(b, i);
        } else if c == b'"' || c == b'\'' {
            let start = i;
            i = quoted_end(b, i);
            out.push(Token {
                kind: Kind::Literal,
                start,
                end: i,
            });
        } else if let Some((quote, hashes, raw)) = raw_string_start(b, i) {
            let start = i;
            i = raw_string_end(b, quote, hashes, raw);
            out.push(Token {
                kind: Kind::Literal,
                start,
                end: i.min(b.len()),
            });
        } else if let Some(kind) = punctuation(c) {
            out.push(Token {
                kind,
                start: i,
                end: i + 1,
            });
            i += 1;
        } else {
            let start = i;
            i = word_end(b, i);
            out.push(Token {
                kind: Kind::Word,
                start,
                end: i,
            });
        }
    }
    out
}

/// Where the `//` comment starting at `i` ends: at its newline (not consumed) or the end.
fn line_comment_end(b: &[u8], mut i: usize) -> usize {
    while i < b.len() && b[i] != b'\n' {
        i += 1;
    }
    i
}

/// Where the `/*` comment starting at `i` ends, just past its `*/`. RON's block comments
/// nest, so the `*/` that closes it is the one that brings the depth back to zero.
fn block_comment_end(b: &[u8], mut i: usize) -> usize {
    let mut depth = 0usize;
    while i < b.len() {
        if b[i..].starts_with(b"/*") {
            depth += 1;
            i += 2;
        } else if b[i..].starts_with(b"*/") {
            depth -= 1;
            i += 2;
            if depth == 0 {
                break;
            }
        } else {
            i += 1;
        }
    }
    i
}

/// Where the string or character literal whose quote (`"` or `'`) is at `i` ends, just
/// past its closing quote (a backslash escapes the byte after it), at most the text's end.
fn quoted_end(b: &[u8], mut i: usize) -> usize {
    let c = b[i];
    i += 1;
    while i < b.len() && b[i] != c {
        i += if b[i] == b'\\' { 2 } else { 1 };
    }
    (i + 1).min(b.len())
}

/// Where a raw string `r#"…"#`, byte string `b"…"` or `br#"…"#` ends, given what
/// [`raw_string_start`] found: its opening quote at `quote`, its count of `hashes` and
/// whether it is raw (no escapes). Just past the closing quote and hashes; past the text's
/// end when it is not closed (the caller clamps).
fn raw_string_end(b: &[u8], quote: usize, hashes: usize, raw: bool) -> usize {
    let mut i = quote + 1;
    while i < b.len() {
        if !raw && b[i] == b'\\' {
            i += 2;
            continue;
        }
        if b[i] == b'"' && b[i + 1..].iter().take_while(|&&x| x == b'#').count() >= hashes {
            i += 1 + hashes;
            break;
        }
        i += 1;
    }
    i
}

/// The token of a one-byte punctuation mark: an opening or closing bracket, a comma or a
/// colon; `None` for any other byte.
fn punctuation(c: u8) -> Option<Kind> {
    match c {
        b'(' | b'[' | b'{' => Some(Kind::Open(c)),
        b')' | b']' | b'}' => Some(Kind::Close),
        b',' => Some(Kind::Comma),
        b':' => Some(Kind::Colon),
        _ => None,
    }
}

/// Where the bare word (identifier, number, `true`…) starting at `i` ends: at the first
/// whitespace, bracket, comma, colon, quote or comment.
fn word_end(b: &[u8], mut i: usize) -> usize {
    while i < b.len()
        && !b[i].is_ascii_whitespace()
        && !matches!(
            b[i],
            b'(' | b'[' | b'{' | b')' | b']' | b'}' | b',' | b':' | b'"'
        )
        && !b[i..].starts_with(b"//")
        && !b[i..].starts_with(b"/*")
    {
        i += 1;
    }
    i
}

/// One step of a path.
enum Segment<'a> {
    Field(&'a str),
    Index(usize),
}

fn segments(path: &str) -> Vec<Segment<'_>> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (name, rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        if !name.is_empty() {
            out.push(Segment::Field(name));
        }
        for index in rest.split('[').filter(|p| !p.is_empty()) {
            if let Ok(i) = index.trim_end_matches(']').parse() {
                out.push(Segment::Index(i));
            }
        }
    }
    out
}

struct Scanner<'a> {
    text: &'a str,
    t: Vec<Token>,
}

impl Scanner<'_> {
    fn word(&self, i: usize) -> &str {
        &self.text[self.t[i].start..self.t[i].end]
    }

    /// The index after the value starting at `i`.
    fn skip_value(&self, mut i: usize) -> usize {
        // An identifier may name a struct or variant whose group follows.
        if i < self.t.len() && self.t[i].kind == Kind::Word {
            i += 1;
            if i >= self.t.len() || !matches!(self.t[i].kind, Kind::Open(_)) {
                return i;
            }
        }
        if i < self.t.len() && matches!(self.t[i].kind, Kind::Open(_)) {
            let mut depth = 0usize;
            while i < self.t.len() {
                match self.t[i].kind {
                    Kind::Open(_) => depth += 1,
                    Kind::Close => {
                        depth -= 1;
                        if depth == 0 {
                            return i + 1;
                        }
                    }
                    _ => {}
                }
                i += 1;
            }
            return i;
        }
        i + 1
    }

    /// The items of the group opened at `open`: `(key token or None, value start)`. A struct's
    /// items have their field name as key; a list's or tuple's none.
    fn items(&self, open: usize) -> Vec<(Option<usize>, usize)> {
        let mut out = Vec::new();
        let mut i = open + 1;
        while i < self.t.len() && self.t[i].kind != Kind::Close {
            if self.t[i].kind == Kind::Comma {
                i += 1;
                continue;
            }
            if self.t[i].kind == Kind::Word
                && self.t.get(i + 1).map(|t| t.kind) == Some(Kind::Colon)
            {
                out.push((Some(i), i + 2));
                i = self.skip_value(i + 2);
            } else {
                out.push((None, i));
                i = self.skip_value(i);
            }
        }
        out
    }

    /// The group a value opens (after its name, through `Some(..)`): `(name token, open)`.
    fn group(&self, mut i: usize) -> Option<(Option<usize>, usize)> {
        loop {
            let name = (self.t.get(i)?.kind == Kind::Word).then_some(i);
            if name.is_some() {
                i += 1;
            }
            let open = i;
            if !matches!(self.t.get(open)?.kind, Kind::Open(_)) {
                return None;
            }
            // `Some(x)`: look through it.
            if name.is_some_and(|n| self.word(n) == "Some") {
                i = open + 1;
                continue;
            }
            return Some((name, open));
        }
    }
}

/// Line and column (1-based) of byte offset `at`.
fn line_column(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before
        .rfind('\n')
        .map_or(before.chars().count(), |n| before[n + 1..].chars().count())
        + 1;
    (line, column)
}

/// Where the field `path` (as `fluids[0].blocks[1].size`) is written in `text`: the line and
/// column of its name (of its value for a list item), or of the deepest part of the path that
/// is written; the file's first value when none is.
pub(crate) fn locate(text: &str, path: &str) -> (usize, usize) {
    let scanner = Scanner {
        text,
        t: tokens(text),
    };
    let Some(first) = (0..scanner.t.len()).next() else {
        return (1, 1);
    };
    let mut at = scanner.t[first].start;
    let mut value = first;
    let segs = segments(path);
    let mut k = 0;
    while k < segs.len() {
        let Some((name, open)) = scanner.group(value) else {
            break;
        };
        match segs[k] {
            Segment::Field(f) => {
                // A variant named in the path (`region.Collider.name`): it is this value's
                // own name.
                if let Some(n) = name
                    && scanner.word(n) == f
                {
                    at = scanner.t[n].start;
                    k += 1;
                    continue;
                }
                let found = scanner
                    .items(open)
                    .into_iter()
                    .find(|(key, _)| key.is_some_and(|key| scanner.word(key) == f));
                let Some((Some(key), v)) = found else {
                    break;
                };
                at = scanner.t[key].start;
                value = v;
            }
            Segment::Index(i) => {
                let Some(&(_, v)) = scanner.items(open).get(i) else {
                    break;
                };
                at = scanner.t[v].start;
                value = v;
            }
        }
        k += 1;
    }
    line_column(text, at)
}

#[cfg(test)]
mod tests {
    use super::locate;

    const TEXT: &str = r##"// a comment with ( and [
Scene(
    duration: 1.0, /* nested /* comment */ ( */
    fluids: [
        Fluid(
            name: "a ( [ string",
            preset: Water(spacing: 0.1),
            blocks: [Block(min: (0.0, 0.0, 0.0), size: (0.5, 0.5, 0.5)),
                     Block(min: (1.0, 0.0, 0.0),
                           size: (0.5, 0.5, 0.5))],
            capacity: Some(100),
            sinks: [Sink(region: Collider(name: r#"dr"ain"#, reach: 0.1))],
        ),
    ],
)"##;

    #[test]
    fn paths_are_found() {
        assert_eq!(locate(TEXT, "duration"), (3, 5));
        assert_eq!(locate(TEXT, "fluids[0]"), (5, 9));
        assert_eq!(locate(TEXT, "fluids[0].blocks[1]"), (9, 22));
        assert_eq!(locate(TEXT, "fluids[0].blocks[1].size"), (10, 28));
        assert_eq!(locate(TEXT, "fluids[0].capacity"), (11, 13));
        assert_eq!(
            locate(TEXT, "fluids[0].sinks[0].region.Collider.reach"),
            (12, 62)
        );
        // Not written: the deepest part that is.
        assert_eq!(locate(TEXT, "fluids[0].emitters[0]"), (5, 9));
        assert_eq!(locate(TEXT, "dt"), (2, 1));
        assert_eq!(locate(TEXT, "fluids[3]"), (4, 5));
        assert_eq!(locate("", "dt"), (1, 1));
    }
}
