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

/// The lines of a text, counted as the reader moves forward: each byte is looked at once
/// (the line of a position is the line of the previous one plus the newlines between them),
/// so that numbering every element of a file costs time linear in its size.
pub(crate) struct Lines<'a> {
    text: &'a str,
    /// The position counted up to, and its 1-based line.
    pos: usize,
    line: usize,
    /// The bytes looked at so far (for the tests: never more than the text's length).
    #[cfg(test)]
    pub scanned: usize,
}

impl<'a> Lines<'a> {
    pub fn new(text: &'a str) -> Self {
        Lines {
            text,
            pos: 0,
            line: 1,
            #[cfg(test)]
            scanned: 0,
        }
    }

    /// The 1-based line of byte `pos` (a position before the last one asked for is counted
    /// from the start again: the reader never goes back, so this does not happen).
    pub fn line_of(&mut self, pos: usize) -> usize {
        let pos = pos.min(self.text.len());
        if pos < self.pos {
            self.pos = 0;
            self.line = 1;
        }
        let between = &self.text.as_bytes()[self.pos..pos];
        self.line += between.iter().filter(|&&b| b == b'\n').count();
        #[cfg(test)]
        {
            self.scanned += between.len();
        }
        self.pos = pos;
        self.line
    }
}

/// How large a file may be, and what stops its reading early.
pub(crate) struct Budget<'a> {
    /// The most elements.
    pub elements: usize,
    /// Asked every [`STOP_EVERY`] elements: true stops the reading.
    pub stop: &'a dyn Fn() -> bool,
}

/// How often (in elements) the reading asks whether to stop.
pub(crate) const STOP_EVERY: usize = 1024;

/// Why [`parse`] gave up.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ParseError {
    /// The document is not well-formed XML.
    Xml(XmlError),
    /// It holds more elements than the budget allows (the line of the first one too many).
    TooManyElements { line: usize },
    /// The budget's stop said so.
    Stopped,
}

impl From<XmlError> for ParseError {
    fn from(e: XmlError) -> Self {
        ParseError::Xml(e)
    }
}

/// The root element of `text`, in time linear in its length.
pub(crate) fn parse(text: &str, budget: &Budget) -> Result<Element, ParseError> {
    let mut reader = quick_xml::Reader::from_str(text);
    reader.check_end_names(true);
    let mut lines = Lines::new(text);
    // The open elements, innermost last; the root once it is closed.
    let mut open: Vec<Element> = Vec::new();
    let mut root: Option<Element> = None;
    let mut elements = 0usize;
    loop {
        let before = reader.buffer_position();
        let event = match reader.read_event() {
            Ok(event) => event,
            Err(e) => {
                return Err(ParseError::Xml(XmlError {
                    line: lines.line_of(reader.buffer_position()),
                    message: e.to_string(),
                }))
            }
        };
        let start = before + leading_space(text.get(before..).unwrap_or(""));
        let line = lines.line_of(start);
        if let Event::Start(_) | Event::Empty(_) = event {
            elements += 1;
            if elements > budget.elements {
                return Err(ParseError::TooManyElements { line });
            }
            if elements.is_multiple_of(STOP_EVERY) && (budget.stop)() {
                return Err(ParseError::Stopped);
            }
        }
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
        return Err(ParseError::Xml(XmlError {
            line: unclosed.line,
            message: format!(
                "the element `{}` is not closed before the end of the file",
                unclosed.name
            ),
        }));
    }
    root.ok_or_else(|| {
        ParseError::Xml(XmlError {
            line: 1,
            message: "the file holds no XML element".into(),
        })
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

    fn parse(text: &str) -> Result<Element, XmlError> {
        let budget = Budget {
            elements: usize::MAX,
            stop: &|| false,
        };
        super::parse(text, &budget).map_err(|e| match e {
            ParseError::Xml(e) => e,
            other => panic!("{other:?}"),
        })
    }

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

    /// The line numbering looks at each byte once, however many elements ask for their line
    /// (counting from the start for each was the quadratic step of issue 40).
    #[test]
    fn numbering_the_lines_of_every_element_scans_the_text_once() {
        let n = 5000;
        let text: String = std::iter::once("<A>\n".to_string())
            .chain((0..n).map(|i| format!("  <B v=\"{i}\"/>\n")))
            .chain(std::iter::once("</A>\n".to_string()))
            .collect();
        let mut lines = Lines::new(&text);
        let mut reader = quick_xml::Reader::from_str(&text);
        let mut empties = 0;
        let mut last = 0;
        loop {
            let before = reader.buffer_position();
            let event = reader.read_event().unwrap();
            if let Event::Eof = event {
                break;
            }
            last = lines.line_of(before + leading_space(&text[before..]));
            if let Event::Empty(_) = event {
                empties += 1;
                assert_eq!(last, empties + 1);
            }
        }
        assert_eq!(
            (empties, last),
            (n, n + 3),
            "the last line: after the closing tag"
        );
        assert!(
            lines.scanned <= text.len(),
            "{} bytes looked at for a text of {}",
            lines.scanned,
            text.len()
        );
    }

    #[test]
    fn the_element_budget_and_the_stop_are_honoured() {
        let text = format!("<A>\n{}</A>\n", "<B/>\n".repeat(3000));
        let few = Budget {
            elements: 100,
            stop: &|| false,
        };
        assert_eq!(
            super::parse(&text, &few),
            Err(ParseError::TooManyElements { line: 101 })
        );
        let asked = std::cell::Cell::new(0);
        let stop = || {
            asked.set(asked.get() + 1);
            true
        };
        let stopping = Budget {
            elements: usize::MAX,
            stop: &stop,
        };
        assert_eq!(super::parse(&text, &stopping), Err(ParseError::Stopped));
        assert_eq!(asked.get(), 1, "asked at the {STOP_EVERY}th element");
    }
}
