//! `<include filename="..."/>`: the included file's scene (what its `<scene>` element holds)
//! takes the place of the element, recursively, before the document is read, as in Mitsuba.
//! Included files are found relative to the including scene's directory (Mitsuba's file
//! resolver); includes nest at most [`MAX_DEPTH`] deep (a cycle is an error, not a hang).
//!
//! The expanded text is what the reader parses; [`Origins`] maps each of its byte offsets back
//! to the file and line it came from, so every error still names the file and line written.

use crate::error::{Error, Result};
use roxmltree::{Document, Node};
use std::ops::Range;
use std::path::Path;

/// Deepest nesting of includes.
pub const MAX_DEPTH: usize = 16;

/// Where the pieces of an expanded text come from.
#[derive(Debug, Default)]
pub struct Origins {
    /// (name, text) of every file read, the scene's own first.
    files: Vec<(String, String)>,
    /// Pieces of the expanded text in order: (start in the expanded text, file, offset in
    /// that file); each runs to the next one's start.
    pieces: Vec<(usize, usize, usize)>,
}

impl Origins {
    /// The file name and 1-based line of byte `at` of the expanded text.
    pub fn locate(&self, at: usize) -> (&str, usize) {
        let i = self.pieces.partition_point(|p| p.0 <= at).saturating_sub(1);
        let Some(&(start, file, offset)) = self.pieces.get(i) else {
            return (self.files.first().map_or("", |f| f.0.as_str()), 1);
        };
        let (name, text) = &self.files[file];
        let off = (offset + (at - start)).min(text.len());
        let line = text.as_bytes()[..off]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        (name, line)
    }

    /// Whether any include was expanded (else offsets are the scene file's own).
    pub fn any(&self) -> bool {
        self.files.len() > 1
    }
}

/// `text` (the scene file `name`, in directory `dir`) with its includes expanded, and where
/// each piece of it comes from.
pub fn expand(text: &str, name: &str, dir: Option<&Path>) -> Result<(String, Origins)> {
    let mut origins = Origins {
        files: vec![(name.to_string(), text.to_string())],
        pieces: Vec::new(),
    };
    let mut out = String::with_capacity(text.len());
    expand_range(&mut origins, &mut out, 0, 0..text.len(), dir, 0)?;
    Ok((out, origins))
}

/// Append `range` of file `file` to `out`, its includes expanded.
fn expand_range(
    origins: &mut Origins,
    out: &mut String,
    file: usize,
    range: Range<usize>,
    dir: Option<&Path>,
    depth: usize,
) -> Result<()> {
    let (name, text) = origins.files[file].clone();
    let includes = {
        let Ok(doc) = Document::parse(&text) else {
            // The reader reports malformed XML of the scene file itself with its line; an
            // included file is parsed below before it gets here.
            origins.pieces.push((out.len(), file, range.start));
            out.push_str(&text[range]);
            return Ok(());
        };
        let mut found = Vec::new();
        for n in doc.descendants().filter(|n| n.has_tag_name("include")) {
            let r = n.range();
            if r.start >= range.start && r.end <= range.end {
                found.push((r.clone(), filename(n, &name, &text)?));
            }
        }
        found
    };
    let mut pos = range.start;
    for (r, filename) in includes {
        origins.pieces.push((out.len(), file, pos));
        out.push_str(&text[pos..r.start]);
        let line = text[..r.start].bytes().filter(|&b| b == b'\n').count() + 1;
        if depth >= MAX_DEPTH {
            return Err(Error::new(format!(
                "{name}:{line}: includes nest deeper than {MAX_DEPTH} (does a file include itself?)"
            )));
        }
        let path = dir.map_or_else(|| Path::new(&filename).to_path_buf(), |d| d.join(&filename));
        let included = std::fs::read_to_string(&path).map_err(|e| {
            Error::new(format!(
                "{name}:{line}: cannot read included file '{}': {e}",
                path.display()
            ))
        })?;
        let inc_name = path.display().to_string();
        let inner = scene_contents(&included, &inc_name)?;
        origins.files.push((inc_name, included));
        let inc = origins.files.len() - 1;
        expand_range(origins, out, inc, inner, dir, depth + 1)?;
        pos = r.end;
    }
    origins.pieces.push((out.len(), file, pos));
    out.push_str(&text[pos..range.end]);
    Ok(())
}

/// The `filename` of an `<include>` (parameters are not substituted in it).
fn filename(n: Node, name: &str, text: &str) -> Result<String> {
    let line = text[..n.range().start]
        .bytes()
        .filter(|&b| b == b'\n')
        .count()
        + 1;
    match n.attribute("filename") {
        Some(f) if f.contains('$') => Err(Error::new(format!(
            "{name}:{line}: <include> 'filename' with a parameter ('{f}') is not supported"
        ))),
        Some(f) => Ok(f.to_string()),
        None => Err(Error::new(format!(
            "{name}:{line}: <include> needs the attribute 'filename'"
        ))),
    }
}

/// The byte range of what the `<scene>` element of an included file holds.
fn scene_contents(text: &str, name: &str) -> Result<Range<usize>> {
    let doc = Document::parse(text)
        .map_err(|e| Error::new(format!("{name}:{}: not well-formed XML: {e}", e.pos().row)))?;
    let root = doc.root_element();
    if root.tag_name().name() != "scene" {
        let line = text[..root.range().start]
            .bytes()
            .filter(|&b| b == b'\n')
            .count()
            + 1;
        return Err(Error::new(format!(
            "{name}:{line}: an included file's root element must be <scene>, got <{}>",
            root.tag_name().name()
        )));
    }
    Ok(match (root.first_child(), root.last_child()) {
        (Some(a), Some(b)) => a.range().start..b.range().end,
        _ => root.range().end..root.range().end,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn origins_map_every_piece_back_to_its_file_and_line() {
        let dir = std::env::temp_dir().join(format!("lodestar-include-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("a.xml"),
            "<scene version=\"3.0.0\">\n  <shape type=\"a\"/>\n  <include filename=\"b.xml\"/>\n</scene>",
        )
        .unwrap();
        std::fs::write(
            dir.join("b.xml"),
            "<scene version=\"3.0.0\">\n\n  <shape type=\"b\"/>\n</scene>",
        )
        .unwrap();
        let main = "<scene version=\"3.0.0\">\n<include filename=\"a.xml\"/>\n<shape type=\"main\"/>\n</scene>";
        let (text, origins) = expand(main, "main.xml", Some(&dir)).unwrap();
        assert!(!text.contains("include"), "{text}");
        let at = |needle: &str| origins.locate(text.find(needle).unwrap());
        assert_eq!(
            at("\"a\""),
            (dir.join("a.xml").display().to_string().as_str(), 2)
        );
        assert_eq!(
            at("\"b\""),
            (dir.join("b.xml").display().to_string().as_str(), 3)
        );
        assert_eq!(at("\"main\""), ("main.xml", 3));
        // A file that includes itself stops at the depth limit, with its line.
        std::fs::write(
            dir.join("loop.xml"),
            "<scene>\n<include filename=\"loop.xml\"/>\n</scene>",
        )
        .unwrap();
        let e = expand(
            "<scene><include filename=\"loop.xml\"/></scene>",
            "m.xml",
            Some(&dir),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("loop.xml:2:") && e.contains("nest deeper"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
