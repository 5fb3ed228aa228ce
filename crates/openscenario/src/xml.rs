//! The XML of a file as a small tree of elements, each with the line it starts on (quick-xml
//! events; text, comments and processing instructions are dropped: a parameter value
//! distribution holds everything in attributes).

use quick_xml::events::{BytesStart, Event};

/// One element: its name, attributes (unescaped, in file order), children and line.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Element {
    pub name: String,
    pub attributes: Vec<(String, String)>,
    pub children: Vec<Element>,
    /// The 1-based line of its start tag.
    pub line: usize,
}

impl Element {
    /// The value of attribute `name`, if given.
    pub fn attribute(&self, name: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }

    /// The children named `name`.
    pub fn children_named<'a>(&'a self, name: &'a str) -> impl Iterator<Item = &'a Element> {
        self.children.iter().filter(move |c| c.name == name)
    }
}

/// A document that is not well-formed XML: the 1-based line and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct XmlError {
    pub line: usize,
    pub message: String,
}

/// The 1-based line of byte `pos` of `text`.
pub(crate) fn line_of(text: &str, pos: usize) -> usize {
    text.get(..pos.min(text.len()))
        .unwrap_or(text)
        .matches('\n')
        .count()
        + 1
}

/// The root element of `text`.
pub(crate) fn parse(text: &str) -> Result<Element, XmlError> {
    let mut reader = quick_xml::Reader::from_str(text);
    reader.check_end_names(true);
    // The open elements, innermost last; the root once it is closed.
    let mut open: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    loop {
        let before = reader.buffer_position();
        let event = reader.read_event().map_err(|e| XmlError {
            line: line_of(text, reader.buffer_position()),
            message: e.to_string(),
        })?;
        let line = line_of(
            text,
            before + leading_space(&text[before.min(text.len())..]),
        );
        match event {
            Event::Start(e) => open.push(element(&e, line)?),
            Event::Empty(e) => close(element(&e, line)?, &mut open, &mut root, line)?,
            Event::End(_) => {
                let done = open.pop().ok_or_else(|| XmlError {
                    line,
                    message: "a closing tag without its opening tag".into(),
                })?;
                close(done, &mut open, &mut root, line)?;
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if let Some(unclosed) = open.last() {
        return Err(XmlError {
            line: unclosed.line,
            message: format!(
                "the element `{}` is not closed before the end of the file",
                unclosed.name
            ),
        });
    }
    root.ok_or_else(|| XmlError {
        line: 1,
        message: "the file holds no XML element".into(),
    })
}

/// The bytes of whitespace `s` starts with (the text between two tags belongs to the event
/// before the next tag: its line is the tag's).
fn leading_space(s: &str) -> usize {
    s.len() - s.trim_start().len()
}

/// Hands a finished element to its parent, or makes it the root.
fn close(
    done: Element,
    open: &mut [Element],
    root: &mut Option<Element>,
    line: usize,
) -> Result<(), XmlError> {
    match open.last_mut() {
        Some(parent) => parent.children.push(done),
        None if root.is_none() => *root = Some(done),
        None => {
            return Err(XmlError {
                line,
                message: format!("a second root element `{}`", done.name),
            })
        }
    }
    Ok(())
}

/// An element from its start tag, attributes unescaped.
fn element(e: &BytesStart, line: usize) -> Result<Element, XmlError> {
    let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
    let mut attributes = Vec::new();
    for a in e.attributes() {
        let a = a.map_err(|err| XmlError {
            line,
            message: format!("element `{name}`: {err}"),
        })?;
        let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let value = a
            .unescape_value()
            .map_err(|err| XmlError {
                line,
                message: format!("element `{name}`, attribute `{key}`: {err}"),
            })?
            .into_owned();
        attributes.push((key, value));
    }
    Ok(Element {
        name,
        attributes,
        children: Vec::new(),
        line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn elements_know_their_lines_and_attributes() {
        let root =
            parse("<?xml version='1.0'?>\n<A x=\"1 &amp; 2\">\n  <B/>\n  <C>\n  </C>\n</A>\n")
                .unwrap();
        assert_eq!((root.name.as_str(), root.line), ("A", 2));
        assert_eq!(root.attribute("x"), Some("1 & 2"));
        let lines: Vec<_> = root
            .children
            .iter()
            .map(|c| (c.name.as_str(), c.line))
            .collect();
        assert_eq!(lines, [("B", 3), ("C", 4)]);
    }

    #[test]
    fn ill_formed_xml_is_refused_at_its_line() {
        let e = parse("<A>\n<B>\n</C>\n</A>").unwrap_err();
        assert_eq!(e.line, 3, "{e:?}");
        let e = parse("<A>\n<B/>\n").unwrap_err();
        assert!(e.message.contains("`A` is not closed"), "{e:?}");
        let e = parse("<A/><B/>").unwrap_err();
        assert!(e.message.contains("second root"), "{e:?}");
        let e = parse("").unwrap_err();
        assert!(e.message.contains("no XML element"), "{e:?}");
    }
}
