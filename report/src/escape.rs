//! Text made safe to put inside markup: one [`escape`] for the report page
//! (HTML), the flight replays (HTML and SVG) and anything else the crate
//! writes as XML.

/// Escapes `text` for element content and for attribute values in either
/// quote style, in HTML and in XML (SVG): `&`, `<`, `>`, `"` and `'` become
/// `&amp;`, `&lt;`, `&gt;`, `&quot;` and `&#39;` (a numeric reference, since
/// HTML 4 has no `&apos;`). Every other character, non-ASCII included, is
/// kept as it is.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped() {
        assert_eq!(
            escape("<a href=\"x\">&'"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
    }

    #[test]
    fn other_text_is_kept() {
        assert_eq!(
            escape("Q(λ), trial 3: 9,999,999"),
            "Q(λ), trial 3: 9,999,999"
        );
        assert_eq!(escape(""), "");
    }
}
