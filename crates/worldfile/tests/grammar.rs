//! The document-level grammar of both languages: one test per rule and per error path.

mod common;

use std::path::{Path, PathBuf};

use common::Scratch;
use worldfile::loader::{load_document, parse_document};
use worldfile::{Dialect, Document, Error, ErrorKind, Limits, LoadOptions};

fn world(src: &str) -> Result<Document, Error> {
    parse_document(
        Path::new("t.world"),
        src.as_bytes().to_vec(),
        Dialect::World,
        &LoadOptions::default(),
    )
}

fn cfg(src: &str) -> Result<Document, Error> {
    parse_document(
        Path::new("t.cfg"),
        src.as_bytes().to_vec(),
        Dialect::Cfg,
        &LoadOptions::default(),
    )
}

fn values(doc: &Document, entity: usize, name: &str) -> Vec<String> {
    let p = doc
        .property(entity, name)
        .unwrap_or_else(|| panic!("no {name}"));
    doc.values(p).iter().map(|v| v.text.to_string()).collect()
}

fn types(doc: &Document) -> Vec<(Option<usize>, String)> {
    (1..doc.entities.len())
        .map(|id| (doc.entity(id).parent, doc.type_name(id).to_string()))
        .collect()
}

fn err(r: Result<Document, Error>) -> Error {
    match r {
        Ok(_) => panic!("expected an error"),
        Err(e) => e,
    }
}

fn at(e: &Error) -> (u32, u32) {
    let l = e.location.as_ref().expect("located");
    (l.line, l.col)
}

// ---- lexical rules --------------------------------------------------------------------------

#[test]
fn comments_strings_numbers() {
    let d = world("# top comment\nx 1.5 # trailing\ns \"a # (not) a comment\"\nn -.5\nglued 1#c\n")
        .unwrap();
    assert_eq!(values(&d, 0, "x"), ["1.5"]);
    assert_eq!(values(&d, 0, "s"), ["a # (not) a comment"]);
    assert_eq!(values(&d, 0, "n"), ["-.5"]);
    assert_eq!(values(&d, 0, "glued"), ["1"]);
}

#[test]
fn exponents_and_missing_final_newline_are_accepted() {
    let d = world("x 1e-3\ny [ 2E2 3 ]").unwrap();
    assert_eq!(values(&d, 0, "x"), ["1e-3"]);
    assert_eq!(values(&d, 0, "y"), ["2E2", "3"]);
}

#[test]
fn illegal_character_is_located() {
    let e = err(world("a 1\nb [1, 2]\n"));
    assert_eq!(e.kind, ErrorKind::IllegalCharacter("`,`".into()));
    assert_eq!(at(&e), (2, 5));
    assert!(
        e.to_string()
            .contains("t.world:2:5: error: illegal character `,`")
    );
    assert!(e.to_string().contains("b [1, 2]"), "{e}");
}

#[test]
fn unterminated_string() {
    let e = err(world("m ( name \"abc\n)\n"));
    assert_eq!(e.kind, ErrorKind::UnterminatedString);
    assert_eq!(at(&e), (1, 10));
}

#[test]
fn crlf_and_cr_line_ends_count_lines() {
    let e = err(world("a 1\r\nb 2\rc ,\n"));
    assert_eq!(at(&e), (3, 3));
}

// ---- properties and tuples ------------------------------------------------------------------

#[test]
fn tuples_and_empty_tuples() {
    let d = world("t [ 1 \"a\" -2 ]\ne [ ]\n").unwrap();
    assert_eq!(values(&d, 0, "t"), ["1", "a", "-2"]);
    assert!(d.property(0, "e").unwrap().is_empty());
}

#[test]
fn tuples_may_span_lines_and_hold_comments() {
    let d = world("pose [ 1 2 # x and y\n 0 90 ]\n").unwrap();
    assert_eq!(values(&d, 0, "pose"), ["1", "2", "0", "90"]);
}

#[test]
fn value_must_be_on_the_name_line() {
    let e = err(world("x\n5\n"));
    assert_eq!(e.kind, ErrorKind::ValueNotOnSameLine("x".into()));
    let e = err(world("m ( x # c\n 5 )\n"));
    assert_eq!(e.kind, ErrorKind::ValueNotOnSameLine("x".into()));
}

#[test]
fn bare_words_are_not_values() {
    let e = err(world("m ( drive diff )\n"));
    assert!(matches!(e.kind, ErrorKind::ExpectedValueOrBody { ref name, .. } if name == "drive"));
    assert_eq!(at(&e), (1, 11));
}

#[test]
fn word_inside_a_tuple() {
    let e = err(world("pose [ 1 e 3 ]\n"));
    assert_eq!(e.kind, ErrorKind::BadTupleElement("word `e`".into()));
    assert_eq!(at(&e), (1, 10));
    let e = err(world("pose [ 1 [ 2 ] ]\n"));
    assert_eq!(e.kind, ErrorKind::BadTupleElement("`[`".into()));
}

#[test]
fn unterminated_tuple() {
    let e = err(world("pose [ 1 2\n"));
    assert_eq!(e.kind, ErrorKind::UnterminatedTuple("pose".into()));
    assert_eq!(at(&e), (1, 6));
}

#[test]
fn bracket_glued_to_name_is_a_word() {
    // `pose[` is one word (words may contain brackets): `pose[ 1` is a property and the `2`
    // after it is a stray number, as in Stage.
    let e = err(world("pose[ 1 2 ]\n"));
    assert_eq!(e.kind, ErrorKind::UnexpectedAtTopLevel("number `2`".into()));
}

#[test]
fn later_property_replaces_whole_tuple_in_worlds() {
    let d = world("m ( x [1 2 3] x [4] )\n").unwrap();
    assert_eq!(values(&d, 1, "x"), ["4"]);
}

#[test]
fn cfg_fields_merge_element_wise_and_tuples_span_lines() {
    let d = cfg("d ( p [\"a\" \"b\"\n \"c\"] p [\"z\"] flag yes )\n").unwrap();
    assert_eq!(values(&d, 1, "p"), ["z", "b", "c"]);
    assert_eq!(values(&d, 1, "flag"), ["yes"]);
    assert_eq!(
        d.values(d.property(1, "flag").unwrap())[0].kind,
        worldfile::ValueKind::Bool
    );
}

#[test]
fn top_level_errors() {
    let e = err(world("5\n"));
    assert_eq!(e.kind, ErrorKind::UnexpectedAtTopLevel("number `5`".into()));
    let e = err(world(")\n"));
    assert_eq!(e.kind, ErrorKind::UnexpectedAtTopLevel("`)`".into()));
    let e = err(world("a b\n"));
    assert!(
        matches!(e.kind, ErrorKind::ExpectedValueOrBody { ref found, .. } if found == "word `b`")
    );
    let e = err(world("lonely   \n"));
    assert!(
        matches!(e.kind, ErrorKind::ExpectedValueOrBody { ref found, .. } if found == "end of file")
    );
}

// ---- entities -------------------------------------------------------------------------------

#[test]
fn nested_entities_in_pre_order() {
    let d = world("a ( x 1 b\n (\n y 2 c ( ) ) ) d ( )\n").unwrap();
    assert_eq!(
        types(&d),
        [
            (Some(0), "a".into()),
            (Some(1), "b".into()),
            (Some(2), "c".into()),
            (Some(0), "d".into())
        ]
    );
    assert_eq!(d.children(1), [2]);
    assert_eq!(values(&d, 2, "y"), ["2"]);
    assert_eq!(d.entity(3).loc.unwrap().line, 3);
}

#[test]
fn body_errors() {
    let e = err(world("m ( 5 )\n"));
    assert!(
        matches!(e.kind, ErrorKind::UnexpectedInBody { ref found, .. } if found == "number `5`")
    );
    let e = err(world("m ( x 1 ( y 2 ) )\n"));
    assert_eq!(e.kind, ErrorKind::StrayOpenParen);
    let e = err(world("m ( x 1\n"));
    assert_eq!(e.kind, ErrorKind::MissingCloseParen("m".into()));
    assert_eq!(at(&e), (1, 1));
    let e = err(world("m ( define a b ( ) )\n"));
    assert_eq!(e.kind, ErrorKind::DefineNotAtTopLevel);
}

// ---- define ---------------------------------------------------------------------------------

#[test]
fn define_inherits_properties_and_copies_children() {
    let src = "define base model ( color \"red\" size [1 1 1] child ( k 1 ) )\n\
               define derived base ( size [2 2 2] other ( ) )\n\
               derived ( name \"a\" own ( ) )\n\
               derived ( name \"b\" color \"blue\" )\n";
    let d = world(src).unwrap();
    let t: Vec<String> = types(&d).into_iter().map(|(_, t)| t).collect();
    assert_eq!(
        t,
        ["model", "child", "other", "own", "model", "child", "other"]
    );
    // Each instance has its own copies of the macro's children.
    assert_eq!(d.children(1), [2, 3, 4]);
    assert_eq!(d.children(5), [6, 7]);
    assert_eq!(values(&d, 1, "size"), ["2", "2", "2"]);
    assert_eq!(values(&d, 1, "color"), ["red"]);
    assert_eq!(values(&d, 5, "color"), ["blue"]);
    assert_eq!(d.macro_name(1), Some("derived"));
    // Inherited properties point into the define; the instance points at itself.
    assert_eq!(d.property(1, "size").unwrap().loc.line, 2);
    assert_eq!(d.entity(5).loc.unwrap().line, 4);
}

#[test]
fn first_definition_wins_with_a_warning() {
    let d = world("define r model ( k 1 )\ndefine r model ( k 2 )\nr ( )\n").unwrap();
    assert_eq!(values(&d, 1, "k"), ["1"]);
    assert_eq!(d.warnings.len(), 1);
    assert!(d.warnings[0].message.contains("already defined"));
}

#[test]
fn macro_parent_may_be_defined_later_but_before_use() {
    let d = world("define a b ( x 1 )\ndefine b model ( y 2 )\na ( )\n").unwrap();
    assert_eq!(types(&d), [(Some(0), "model".into())]);
    // A macro used before its definition is just a type word.
    let d = world("c ( )\ndefine c model ( )\n").unwrap();
    assert_eq!(types(&d), [(Some(0), "c".into())]);
}

#[test]
fn define_errors() {
    assert_eq!(
        err(world("define a ( x 1 )\n")).kind,
        ErrorKind::MissingMacroName
    );
    assert_eq!(
        err(world("define a b c ( )\n")).kind,
        ErrorKind::ExtraMacroTokens("c".into())
    );
    assert_eq!(
        err(world("define a b )\n")).kind,
        ErrorKind::MisplacedCloseParen
    );
    assert_eq!(
        err(world("define a b ( x 1\n")).kind,
        ErrorKind::MissingCloseParen("a".into())
    );
}

#[test]
fn macro_cycles_are_errors() {
    let e = err(world("define position position ( )\nposition ( )\n"));
    assert_eq!(
        e.kind,
        ErrorKind::MacroCycle(vec!["position".into(), "position".into()])
    );
    let e = err(world("define a b ( )\ndefine b a ( )\na ( )\n"));
    assert!(matches!(e.kind, ErrorKind::MacroCycle(ref c) if c.len() == 3));
    let e = err(world("define a model ( a ( ) )\na ( )\n"));
    assert!(matches!(e.kind, ErrorKind::MacroCycle(_)));
}

#[test]
fn errors_in_unused_macros_are_not_reported() {
    // Upstream only checks parentheses when defining; the body is parsed at each use.
    assert!(world("define a model 5 ( x )\n").is_ok());
    assert!(world("define a model 5 ( x )\na ( )\n").is_err());
}

#[test]
fn macro_bombs_are_bounded() {
    let mut src = String::from("define m0 model ( x 1 )\n");
    for i in 1..40 {
        src.push_str(&format!(
            "define m{i} model ( m{p} ( ) m{p} ( ) )\n",
            p = i - 1
        ));
    }
    src.push_str("m39 ( )\n");
    let opts = LoadOptions {
        limits: Limits {
            max_entities: 100_000,
            ..Limits::default()
        },
        ..LoadOptions::default()
    };
    let e = parse_document(
        Path::new("b.world"),
        src.into_bytes(),
        Dialect::World,
        &opts,
    )
    .unwrap_err();
    assert!(matches!(e.kind, ErrorKind::TooLarge(_)), "{e}");
}

#[test]
fn deep_nesting_is_bounded() {
    let src = "m ( ".repeat(10_000);
    let e = err(world(&src));
    assert!(matches!(e.kind, ErrorKind::TooLarge(_)), "{e}");
}

// ---- globals --------------------------------------------------------------------------------

#[test]
fn units_and_test_flag() {
    let d = world("unit_length \"mm\"\nunit_angle \"radians\"\n").unwrap();
    assert_eq!((d.units.length, d.units.angle), (0.001, 1.0));
    let d = world("unit_length \"furlong\"\n").unwrap();
    assert_eq!(d.units.length, 1.0);
    assert_eq!(d.warnings.len(), 1);
    assert_eq!(err(world("test 1\n")).kind, ErrorKind::TestFile);
    assert!(world("test 0\n").is_ok());
}

#[test]
fn unknown_unit_words_are_warnings_naming_the_words_stage_takes() {
    let d = world("unit_length \"furlong\"\nunit_angle \"grad\"\n").unwrap();
    assert_eq!(
        (d.units.length, d.units.angle),
        (1.0, std::f64::consts::PI / 180.0)
    );
    let messages: Vec<&str> = d.warnings.iter().map(|w| w.message.as_str()).collect();
    assert_eq!(
        messages,
        [
            "unit_length \"furlong\" is not \"m\", \"cm\" or \"mm\"; using metres as Stage does",
            "unit_angle \"grad\" is not \"degrees\" or \"radians\"; using degrees as Stage does",
        ]
    );
}

// ---- include --------------------------------------------------------------------------------

fn load(path: &Path, dialect: Dialect, stage_path: Vec<PathBuf>) -> Result<Document, Error> {
    let opts = LoadOptions {
        stage_path,
        ..LoadOptions::default()
    };
    load_document(path, dialect, &opts)
}

#[test]
fn includes_resolve_against_the_top_level_file() {
    let s = Scratch::new();
    s.file("inner/b.inc", "from_top_inner 1\n");
    s.file("sub/inner/b.inc", "from_sub_inner 1\n");
    s.file("sub/a.inc", "include \"inner/b.inc\"\na 1\n");
    let top = s.file(
        "w.world",
        "include \"sub/a.inc\" # rest ignored ( \nafter 1\n",
    );
    let d = load(&top, Dialect::World, vec![]).unwrap();
    assert!(d.property(0, "from_top_inner").is_some());
    assert!(d.property(0, "from_sub_inner").is_none());
    assert!(d.property(0, "a").is_some() && d.property(0, "after").is_some());
    assert_eq!(d.sources.files().len(), 3);
    // Locations are real positions in each file.
    assert_eq!(d.property(0, "after").unwrap().loc.line, 2);
}

#[test]
fn include_rest_of_line_is_kept_in_cfg_files() {
    let s = Scratch::new();
    s.file("a.inc", "a 1\n");
    let top = s.file("c.cfg", "include \"a.inc\" b 2\n");
    let d = load(&top, Dialect::Cfg, vec![]).unwrap();
    assert_eq!(values(&d, 0, "b"), ["2"]);
    let top = s.file("w.world", "include \"a.inc\" b 2\n");
    let d = load(&top, Dialect::World, vec![]).unwrap();
    assert!(d.property(0, "b").is_none());
}

#[test]
fn include_on_last_line_without_newline() {
    // Stage hangs here; we stop at end of file.
    let s = Scratch::new();
    s.file("a.inc", "a 1");
    let top = s.file("w.world", "include \"a.inc\"");
    let d = load(&top, Dialect::World, vec![]).unwrap();
    assert!(d.property(0, "a").is_some());
}

#[test]
fn missing_include_names_the_path_and_the_chain() {
    let s = Scratch::new();
    s.file("a.inc", "x 1\ninclude \"nope.inc\"\n");
    let top = s.file("w.world", "\ninclude \"a.inc\"\n");
    let e = load(&top, Dialect::World, vec![]).unwrap_err();
    assert!(matches!(
        e.kind,
        ErrorKind::Io {
            what: "include file",
            ..
        }
    ));
    assert_eq!(at(&e), (2, 9));
    assert_eq!(e.included_from.len(), 1);
    assert_eq!(e.included_from[0].line, 2);
    assert!(e.to_string().contains("included from"), "{e}");
}

#[test]
fn stagepath_fallback() {
    let s = Scratch::new();
    s.file("lib/common.inc", "shared 1\n");
    let top = s.file("w/w.world", "include \"elsewhere/common.inc\"\n");
    assert!(load(&top, Dialect::World, vec![]).is_err());
    let d = load(&top, Dialect::World, vec![s.dir.join("lib")]).unwrap();
    assert!(d.property(0, "shared").is_some());
    // Player's cfg parser has no search path.
    let top = s.file("w/c.cfg", "include \"elsewhere/common.inc\"\n");
    assert!(load(&top, Dialect::Cfg, vec![s.dir.join("lib")]).is_err());
}

#[test]
fn include_cycles_are_errors() {
    let s = Scratch::new();
    s.file("a.inc", "include \"b.inc\"\n");
    s.file("b.inc", "include \"a.inc\"\n");
    let top = s.file("w.world", "include \"a.inc\"\n");
    let e = load(&top, Dialect::World, vec![]).unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::IncludeCycle(ref c) if c.len() == 3),
        "{e}"
    );
    let top = s.file("self.world", "include \"self.world\"\n");
    assert!(matches!(
        load(&top, Dialect::World, vec![]).unwrap_err().kind,
        ErrorKind::IncludeCycle(_)
    ));
}

#[test]
fn include_syntax_errors() {
    assert_eq!(err(world("include\"a.inc\"\n")).kind, ErrorKind::BadInclude);
    assert_eq!(err(world("include a.inc\n")).kind, ErrorKind::BadInclude);
    assert_eq!(err(world("include ")).kind, ErrorKind::BadInclude);
    assert_eq!(
        err(world("include \"a.inc\n")).kind,
        ErrorKind::UnterminatedString
    );
}

#[test]
fn include_inside_an_entity_splices_text() {
    let s = Scratch::new();
    s.file("body.inc", "k 7\n");
    let top = s.file("w.world", "m (\n include \"body.inc\"\n)\n");
    let d = load(&top, Dialect::World, vec![]).unwrap();
    assert_eq!(values(&d, 1, "k"), ["7"]);
    // As in Stage, `include` there is also a property nobody reads.
    assert_eq!(values(&d, 1, "include"), ["body.inc"]);
}

#[test]
fn cfg_plugin_statement() {
    let d = cfg("plugin \"libfoo\"\ndriver ( name \"x\" plugin \"inner\" )\n").unwrap();
    assert_eq!(d.plugins.len(), 1);
    assert_eq!(d.plugins[0].0, "libfoo");
    assert_eq!(values(&d, 1, "plugin"), ["inner"]);
    assert_eq!(err(cfg("plugin 5\n")).kind, ErrorKind::BadPlugin);
}

#[test]
fn unused_properties_are_reported() {
    let d = world("m ( a 1 )\n").unwrap();
    let w = d.unused_property_warnings();
    assert_eq!(w.len(), 1);
    assert_eq!(
        w[0].to_string(),
        "t.world:1:5: warning: property `a` in `m` is defined but not used"
    );
}
