//! HTML pieces of a page: escaping, numbers, tables and the page around them.
//! Everything is inline (one `<style>`, no scripts, no fonts, no links out).

/// `text` with `&`, `<`, `>` and quotes escaped for HTML text and attributes.
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

pub use crate::numbers::number;

/// A number and its unit (`0.0240 m`); the unit is left out when empty or `-`.
pub fn with_unit(v: f64, unit: &str) -> String {
    match unit {
        "" | "-" | "–" => number(v),
        unit => format!("{} {}", number(v), escape(unit)),
    }
}

/// `name [unit]`, escaped, for table headers and axis labels.
pub fn label(name: &str, unit: &str) -> String {
    escape(&crate::numbers::header(name, Some(unit)))
}

/// `name [unit]` for a figure's axis or title, as plain text: the SVG backend escapes
/// what it draws, so text escaped here would show its entities (`&lt;1&gt;`).
pub fn svg_label(name: &str, unit: &str) -> String {
    crate::numbers::header(name, Some(unit))
}

/// A table: escaped header cells, and body cells that are already HTML.
pub fn table(headers: &[String], rows: &[Vec<String>]) -> String {
    let mut out = String::from("<div class=\"scroll\"><table><thead><tr>");
    for h in headers {
        out.push_str(&format!("<th>{}</th>", escape(h)));
    }
    out.push_str("</tr></thead><tbody>");
    for row in rows {
        out.push_str("<tr>");
        for cell in row {
            out.push_str(&format!("<td>{cell}</td>"));
        }
        out.push_str("</tr>");
    }
    out.push_str("</tbody></table></div>\n");
    out
}

/// A figure with its caption; `svg` is an `<svg>` element (or a note).
pub fn figure(svg: &str, caption: &str) -> String {
    format!("<figure>{svg}<figcaption>{caption}</figcaption></figure>\n")
}

/// The whole page. Its head is formatted apart and the body appended to a string of
/// the final length, so a large report is held once and its copy, not a doubling
/// buffer's slack.
pub fn page(title: &str, body: &str) -> String {
    let head = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{}</title><style>{STYLE}</style></head><body>\n",
        escape(title)
    );
    const TAIL: &str = "</body></html>\n";
    let mut page = String::with_capacity(head.len() + body.len() + TAIL.len());
    page.push_str(&head);
    page.push_str(body);
    page.push_str(TAIL);
    page
}

const STYLE: &str = "\
body{font-family:sans-serif;max-width:1240px;margin:1em auto;padding:0 1em;color:#222;line-height:1.4}\
h1{font-size:1.6em}h2{border-bottom:2px solid #1f77b4;margin-top:2em}h3{margin-top:1.5em}\
table{border-collapse:collapse;font-size:0.85em;margin:0.5em 0}\
th,td{border:1px solid #ccc;padding:2px 6px;text-align:right;white-space:nowrap}\
th{background:#eef3f8}td:first-child,th:first-child{text-align:left}\
.scroll{overflow-x:auto}\
figure{display:inline-block;width:min-content;margin:0.5em 1em 0.5em 0;vertical-align:top}\
figcaption{font-size:0.8em;color:#555}\
.warn{background:#fff3cd;border-left:4px solid #e0a800;padding:4px 8px}\
.bad{background:#f8d7da;border-left:4px solid #c82333;padding:4px 8px}\
.note{color:#555;font-size:0.9em}\
dt{font-weight:bold}dd{margin:0 0 0.5em 1.5em}";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_four_significant_digits() {
        assert_eq!(number(0.024), "0.024");
        assert_eq!(number(0.123456), "0.1235");
        assert_eq!(number(123.456), "123.5");
        assert_eq!(number(1.5e-7), "1.500e-7");
        assert_eq!(number(2.5e6), "2.500e6");
        assert_eq!(number(0.0), "0");
        assert_eq!(number(f64::NAN), "–");
    }

    #[test]
    fn html_is_escaped() {
        assert_eq!(
            escape("<a href=\"x\">&</a>"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&lt;/a&gt;"
        );
        assert_eq!(with_unit(0.5, "kg/s"), "0.5 kg/s");
        assert_eq!(with_unit(0.5, "-"), "0.5");
    }

    #[test]
    fn a_unit_with_markup_is_escaped_once_in_tables_and_once_in_figures() {
        assert_eq!(label("y", "<1>"), "y [&lt;1&gt;]");
        let svg = super::super::plots::pareto(
            &format!("Pareto chart: {}", svg_label("y", "<1>")),
            &[("a".into(), 1.0)],
        );
        assert!(svg.contains("Pareto chart: y [&lt;1&gt;]"), "{svg}");
        assert!(!svg.contains("&amp;lt;"), "escaped twice: {svg}");
    }
}
