//! Tokenizer shared by the worldfile and cfg languages (stage-worldfile.md §2, player-cfg.md §2).
//!
//! Each token class is a small `nom` recogniser over bytes; [`next_token`] picks one by the first
//! byte exactly as upstream does. Blanks, comments and line ends are real tokens because where
//! they may appear differs by context (a value must be on its name's line, a `(` may not be).
//! `include` is not handled here but by the loader, which splices the included tokens in.

use nom::branch::alt;
use nom::bytes::complete::{tag, take_till, take_while, take_while1};
use nom::character::complete::{one_of, satisfy};
use nom::combinator::{opt, recognize};
use nom::sequence::pair;
use nom::{IResult, Parser};
use serde::Serialize;

use crate::error::ErrorKind;
use crate::source::Location;

/// Which of the two sibling languages is being read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Dialect {
    /// Stage 4.1.1 `.world` / `.inc`.
    World,
    /// Player 3.0.2 `.cfg`.
    Cfg,
}

/// Token classes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum TokenKind {
    /// `# ...` up to the end of the line.
    Comment,
    /// A name: letter, then letters, digits, `.-_[]` (and `:` in cfg files).
    Word,
    /// A run of `+-.0123456789` (plus an exponent, which we accept and Stage does not).
    Number,
    /// A double-quoted string; the text excludes the quotes.
    Str,
    /// `true`, `false`, `yes`, `no` (cfg files only).
    Bool,
    /// A run of spaces and tabs.
    Space,
    /// A line end: CR, LF, CRLF or LFCR.
    Eol,
    /// `(`
    Open,
    /// `)`
    Close,
    /// `[`
    OpenTuple,
    /// `]`
    CloseTuple,
}

/// One token: its class, where it starts, and where its text is in its [`TokenStream`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Token {
    /// Its class.
    pub kind: TokenKind,
    /// Where its text is in the stream's text (a string's text without the quotes; empty for
    /// blanks and line ends).
    pub text: TextSpan,
    /// Where it starts.
    pub loc: Location,
}

/// A byte range of a [`TokenStream`]'s text. 32-bit offsets (the stream refuses text past
/// 4 GiB) keep the records that name words, one per entity and property, small.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextSpan {
    /// First byte.
    pub start: u32,
    /// Length in bytes.
    pub len: u32,
}

impl TextSpan {
    /// The byte range it covers.
    pub(crate) fn range(self) -> std::ops::Range<usize> {
        self.start as usize..self.start as usize + self.len as usize
    }
}

/// [`TokenStream::push`] refused a token: the stream's text would pass 4 GiB, beyond what a
/// [`TextSpan`] can address.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextTooLong;

/// Tokens in order, with their texts one after another in a single string: a 10,000-robot
/// worldfile has hundreds of thousands of tokens, and one allocation each would cost more than
/// reading them.
#[derive(Clone, Debug, Default)]
pub struct TokenStream {
    tokens: Vec<Token>,
    text: String,
}

impl TokenStream {
    /// An empty stream.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends a token with this text; refused (nothing appended) when the stream's text
    /// would pass what a [`TextSpan`] addresses.
    pub fn push(&mut self, kind: TokenKind, text: &str, loc: Location) -> Result<(), TextTooLong> {
        let end = self.text.len() + text.len();
        let (Ok(start), Ok(len), Ok(_)) = (
            u32::try_from(self.text.len()),
            u32::try_from(text.len()),
            u32::try_from(end),
        ) else {
            return Err(TextTooLong);
        };
        self.text.push_str(text);
        self.tokens.push(Token {
            kind,
            text: TextSpan { start, len },
            loc,
        });
        Ok(())
    }

    /// The text of every token, one after another: what a [`TextSpan`] indexes once the
    /// tokens themselves are no longer needed.
    pub fn into_text(self) -> String {
        self.text
    }

    /// The tokens in order.
    pub fn tokens(&self) -> &[Token] {
        &self.tokens
    }

    /// Number of tokens.
    pub fn len(&self) -> usize {
        self.tokens.len()
    }

    /// Whether there are no tokens.
    pub fn is_empty(&self) -> bool {
        self.tokens.is_empty()
    }

    /// The text of a token of this stream.
    ///
    /// # Panics
    /// If the token is not from this stream.
    pub fn text(&self, tok: &Token) -> &str {
        self.span_text(tok.text)
    }

    /// The text of a span of this stream's text.
    ///
    /// # Panics
    /// If the span is not from this stream.
    pub fn span_text(&self, span: TextSpan) -> &str {
        &self.text[span.range()]
    }

    /// The bytes of a span of this stream's text (for comparisons, which need no UTF-8
    /// boundary checks).
    ///
    /// # Panics
    /// If the span is not from this stream.
    pub fn span_bytes(&self, span: TextSpan) -> &[u8] {
        &self.text.as_bytes()[span.range()]
    }
}

impl Token {
    /// How the token is named in messages: "word `x`", "number `1`", "end of line", ...;
    /// `text` is its text.
    pub fn describe(&self, text: &str) -> String {
        match self.kind {
            TokenKind::Comment => "a comment".into(),
            TokenKind::Word => format!("word `{text}`"),
            TokenKind::Number => format!("number `{text}`"),
            TokenKind::Str => format!("string \"{text}\""),
            TokenKind::Bool => format!("boolean `{text}`"),
            TokenKind::Space => "blank".into(),
            TokenKind::Eol => "end of line".into(),
            TokenKind::Open => "`(`".into(),
            TokenKind::Close => "`)`".into(),
            TokenKind::OpenTuple => "`[`".into(),
            TokenKind::CloseTuple => "`]`".into(),
        }
    }

    /// The text to underline in a diagnostic; `text` is its text.
    pub fn snippet(&self, text: &str) -> String {
        match self.kind {
            TokenKind::Str => format!("\"{text}\""),
            TokenKind::Eol => String::new(),
            TokenKind::Open => "(".into(),
            TokenKind::Close => ")".into(),
            TokenKind::OpenTuple => "[".into(),
            TokenKind::CloseTuple => "]".into(),
            _ => text.to_string(),
        }
    }
}

/// A recognised token: its class, how many bytes it spans, and the byte range of its text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lexeme {
    /// Class.
    pub kind: TokenKind,
    /// Bytes consumed from the input.
    pub len: usize,
    /// Byte range of the token's text within the consumed bytes.
    pub text: (usize, usize),
}

type Res<'a> = IResult<&'a [u8], &'a [u8]>;

fn is_blank(c: u8) -> bool {
    c == b' ' || c == b'\t'
}

fn is_number_char(c: u8) -> bool {
    matches!(c, b'+' | b'-' | b'.' | b'0'..=b'9')
}

fn word(dialect: Dialect) -> impl Fn(&[u8]) -> Res<'_> {
    move |input| {
        recognize(pair(
            satisfy(|c: char| c.is_ascii_alphabetic()),
            take_while(move |c: u8| {
                c.is_ascii_alphanumeric()
                    || matches!(c, b'.' | b'-' | b'_' | b'[' | b']')
                    || (dialect == Dialect::Cfg && c == b':')
            }),
        ))
        .parse(input)
    }
}

fn exponent(input: &[u8]) -> Res<'_> {
    recognize((
        one_of("eE"),
        opt(one_of("+-")),
        take_while1(|c: u8| c.is_ascii_digit()),
    ))
    .parse(input)
}

fn number(input: &[u8]) -> Res<'_> {
    recognize(pair(take_while1(is_number_char), opt(exponent))).parse(input)
}

fn comment(input: &[u8]) -> Res<'_> {
    recognize(pair(tag("#"), take_till(|c| c == b'\n' || c == b'\r'))).parse(input)
}

fn space(input: &[u8]) -> Res<'_> {
    take_while1(is_blank)(input)
}

fn eol(input: &[u8]) -> Res<'_> {
    alt((tag("\r\n"), tag("\n\r"), tag("\r"), tag("\n"))).parse(input)
}

/// The body of a string after its opening quote, up to (not including) the closing quote.
fn string_body(dialect: Dialect) -> impl Fn(&[u8]) -> Res<'_> {
    move |input| {
        take_till(move |c| c == b'"' || c == b'\n' || (dialect == Dialect::World && c == b'\r'))(
            input,
        )
    }
}

/// Recognises the token at the start of `input` (which must not be empty).
///
/// Errors are the tokenizer's: an illegal first byte, or a string not closed on its line.
pub fn next_token(input: &[u8], dialect: Dialect) -> Result<Lexeme, ErrorKind> {
    let first = input[0];
    let whole = |kind, rest: &[u8]| {
        let len = input.len() - rest.len();
        Lexeme {
            kind,
            len,
            text: (0, len),
        }
    };
    match first {
        b'#' => {
            let (rest, _) = comment(input).map_err(|_| ErrorKind::UnterminatedString)?;
            Ok(whole(TokenKind::Comment, rest))
        }
        c if c.is_ascii_alphabetic() => {
            let (rest, text) =
                word(dialect)(input).map_err(|_| ErrorKind::IllegalCharacter(byte_name(c)))?;
            let kind =
                if dialect == Dialect::Cfg && matches!(text, b"true" | b"false" | b"yes" | b"no") {
                    TokenKind::Bool
                } else {
                    TokenKind::Word
                };
            Ok(whole(kind, rest))
        }
        c if is_number_char(c) => {
            let (rest, _) = number(input).map_err(|_| ErrorKind::IllegalCharacter(byte_name(c)))?;
            Ok(whole(TokenKind::Number, rest))
        }
        c if is_blank(c) => {
            let (rest, _) = space(input).map_err(|_| ErrorKind::IllegalCharacter(byte_name(c)))?;
            Ok(whole(TokenKind::Space, rest))
        }
        b'"' => {
            let body = &input[1..];
            let (rest, text) =
                string_body(dialect)(body).map_err(|_| ErrorKind::UnterminatedString)?;
            if rest.first() != Some(&b'"') {
                return Err(ErrorKind::UnterminatedString);
            }
            Ok(Lexeme {
                kind: TokenKind::Str,
                len: 1 + text.len() + 1,
                text: (1, 1 + text.len()),
            })
        }
        b'(' => Ok(single(TokenKind::Open)),
        b')' => Ok(single(TokenKind::Close)),
        b'[' => Ok(single(TokenKind::OpenTuple)),
        b']' => Ok(single(TokenKind::CloseTuple)),
        b'\r' | b'\n' => {
            let (rest, _) =
                eol(input).map_err(|_| ErrorKind::IllegalCharacter(byte_name(first)))?;
            let len = input.len() - rest.len();
            Ok(Lexeme {
                kind: TokenKind::Eol,
                len,
                text: (0, 0),
            })
        }
        other => Err(ErrorKind::IllegalCharacter(byte_name(other))),
    }
}

fn single(kind: TokenKind) -> Lexeme {
    Lexeme {
        kind,
        len: 1,
        text: (0, 1),
    }
}

/// How a byte is named in the "illegal character" message.
pub fn byte_name(c: u8) -> String {
    match c {
        b' '..=b'~' => format!("`{}`", c as char),
        b'\t' => "TAB".into(),
        0 => "NUL byte".into(),
        _ => format!("byte 0x{c:02X}"),
    }
}

/// Length of the rest of the line starting at `input`, including its line end (CR, LF, CRLF or
/// LFCR), and whether a line end was found. Used to discard the tail of a worldfile `include`
/// line, which upstream skips up to the next LF.
pub fn rest_of_line(input: &[u8]) -> (usize, bool) {
    let body = input
        .iter()
        .position(|&c| c == b'\n' || c == b'\r')
        .unwrap_or(input.len());
    match eol(&input[body..]) {
        Ok((rest, _)) => (input.len() - rest.len(), true),
        Err(_) => (body, false),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lex_all(src: &str, dialect: Dialect) -> Result<Vec<(TokenKind, String)>, ErrorKind> {
        let mut out = Vec::new();
        let mut input = src.as_bytes();
        while !input.is_empty() {
            let lx = next_token(input, dialect)?;
            let text = String::from_utf8_lossy(&input[lx.text.0..lx.text.1]).into_owned();
            out.push((lx.kind, text));
            input = &input[lx.len..];
        }
        Ok(out)
    }

    use TokenKind::*;

    #[test]
    fn words_may_contain_brackets_dots_dashes() {
        let toks = lex_all("point[3] a.b-c_d", Dialect::World).unwrap();
        assert_eq!(
            toks,
            vec![
                (Word, "point[3]".into()),
                (Space, " ".into()),
                (Word, "a.b-c_d".into())
            ]
        );
    }

    #[test]
    fn colon_is_a_word_character_only_in_cfg() {
        assert_eq!(
            lex_all("a:b", Dialect::Cfg).unwrap(),
            vec![(Word, "a:b".into())]
        );
        assert_eq!(
            lex_all("a:b", Dialect::World),
            Err(ErrorKind::IllegalCharacter("`:`".into()))
        );
    }

    #[test]
    fn booleans_only_in_cfg() {
        assert_eq!(
            lex_all("yes", Dialect::Cfg).unwrap(),
            vec![(Bool, "yes".into())]
        );
        assert_eq!(
            lex_all("yes", Dialect::World).unwrap(),
            vec![(Word, "yes".into())]
        );
        assert_eq!(
            lex_all("yesno", Dialect::Cfg).unwrap(),
            vec![(Word, "yesno".into())]
        );
    }

    #[test]
    fn numbers_are_runs_of_sign_dot_digit() {
        let toks = lex_all("1.2.3 +5 - -.5 10cm", Dialect::World).unwrap();
        let nums: Vec<_> = toks
            .iter()
            .filter(|t| t.0 == Number)
            .map(|t| t.1.as_str())
            .collect();
        assert_eq!(nums, vec!["1.2.3", "+5", "-", "-.5", "10"]);
        assert_eq!(toks.last().unwrap(), &(Word, "cm".into()));
    }

    #[test]
    fn exponents_are_accepted() {
        assert_eq!(
            lex_all("1e-3 2E5 3e", Dialect::World).unwrap(),
            vec![
                (Number, "1e-3".into()),
                (Space, " ".into()),
                (Number, "2E5".into()),
                (Space, " ".into()),
                (Number, "3".into()),
                (Word, "e".into())
            ]
        );
    }

    #[test]
    fn strings_and_comments() {
        let toks = lex_all("\"a # (b)\" x#c ( )", Dialect::World).unwrap();
        assert_eq!(toks[0], (Str, "a # (b)".into()));
        assert_eq!(toks[2], (Word, "x".into()));
        assert_eq!(toks[3], (Comment, "#c ( )".into()));
        assert_eq!(
            lex_all("\"\"", Dialect::World).unwrap(),
            vec![(Str, "".into())]
        );
    }

    #[test]
    fn unterminated_strings() {
        assert_eq!(
            lex_all("\"abc", Dialect::World),
            Err(ErrorKind::UnterminatedString)
        );
        assert_eq!(
            lex_all("\"a\nb\"", Dialect::World),
            Err(ErrorKind::UnterminatedString)
        );
        assert_eq!(
            lex_all("\"a\rb\"", Dialect::World),
            Err(ErrorKind::UnterminatedString)
        );
        // A CR inside a cfg string is kept, as Player does.
        assert_eq!(
            lex_all("\"a\rb\"", Dialect::Cfg).unwrap(),
            vec![(Str, "a\rb".into())]
        );
    }

    #[test]
    fn line_ends() {
        let toks = lex_all("\r\n\n\r\r\n", Dialect::World).unwrap();
        assert_eq!(toks.iter().filter(|t| t.0 == Eol).count(), 3);
    }

    #[test]
    fn illegal_bytes() {
        for (src, name) in [
            (",", "`,`"),
            ("_x", "`_`"),
            ("=", "`=`"),
            ("{", "`{`"),
            ("\x0c", "byte 0x0C"),
            ("\0", "NUL byte"),
            ("\u{e9}", "byte 0xC3"),
        ] {
            assert_eq!(
                lex_all(src, Dialect::World),
                Err(ErrorKind::IllegalCharacter(name.into())),
                "{src:?}"
            );
        }
    }

    #[test]
    fn rest_of_line_stops_at_any_line_end_or_eof() {
        assert_eq!(rest_of_line(b" # x\nnext"), (5, true));
        assert_eq!(rest_of_line(b" x\r\nnext"), (4, true));
        assert_eq!(rest_of_line(b" x"), (2, false));
    }
}
