//! Writing the page: escaping, the shell, and the sections run and sweep pages share.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Text made safe for HTML content and attribute values.
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

/// A file name as a relative link: each byte outside a safe set percent-encoded, so a name
/// with spaces, `#` or `?` still resolves.
pub fn href(name: &str) -> String {
    let mut out = String::new();
    for b in name.bytes() {
        if b.is_ascii_alphanumeric() || b"-_.~/".contains(&b) {
            out.push(b as char);
        } else {
            let _ = write!(out, "%{b:02X}");
        }
    }
    out
}

const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1100px;padding:0 1em;color:#222}\
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:2em;border-bottom:1px solid #ddd}\
table{border-collapse:collapse;font-size:.9em;margin:.5em 0}td,th{border:1px solid #ccc;padding:.2em .5em;text-align:left}\
th{background:#f4f4f4}pre{background:#f7f7f7;padding:.7em;white-space:pre-wrap}\
figure{display:inline-block;margin:.5em;vertical-align:top}figcaption{font-size:.85em;color:#555}\
figure svg,figure img{max-width:520px;height:auto;border:1px solid #eee}\
.ok{color:#176917}.failed,.interrupted,.stopped{color:#a31515}.pending,.running{color:#8a6d00}";

/// Counts the images that loaded and those that did not, once the page has loaded.
const SELF_CHECK: &str = "<script>window.addEventListener('load',function(){var ok=0,bad=0;\
document.querySelectorAll('img').forEach(function(i){if(i.complete&&i.naturalWidth>0){ok++}else{bad++}});\
document.body.setAttribute('data-images',ok+' loaded, '+bad+' broken')});</script>";

/// The whole page around `body`.
pub fn page(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title><style>{STYLE}</style>\
         </head>\n<body>\n{body}\n{SELF_CHECK}\n</body></html>\n",
        escape(title)
    )
}

/// A two-column table of names and values.
pub fn fields(rows: &[(&str, String)]) -> String {
    let mut s = String::from("<table>\n");
    for (k, v) in rows {
        let _ = writeln!(s, "<tr><th>{}</th><td>{}</td></tr>", escape(k), escape(v));
    }
    s.push_str("</table>\n");
    s
}

/// The first `max_rows` rows of a CSV text as a table, with how many were left out.
pub fn csv_table(text: &str, max_rows: usize) -> String {
    let mut lines = text.lines();
    let Some(header) = lines.next() else { return String::from("<p>(empty)</p>\n") };
    let mut s = String::from("<table>\n<tr>");
    for h in header.split(',') {
        let _ = write!(s, "<th>{}</th>", escape(h));
    }
    s.push_str("</tr>\n");
    let rows: Vec<&str> = lines.collect();
    for line in rows.iter().take(max_rows) {
        s.push_str("<tr>");
        for cell in line.split(',') {
            let _ = write!(s, "<td>{}</td>", escape(cell));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
    if rows.len() > max_rows {
        let _ = writeln!(s, "<p>… {} more row(s) in the file.</p>", rows.len() - max_rows);
    }
    s
}

/// An SVG file's markup to place inline (its XML declaration and doctype dropped), or
/// `None` if it is not an SVG this page can inline.
pub fn inline_svg(text: &str) -> Option<&str> {
    let start = text.find("<svg")?;
    let end = text.rfind("</svg>")? + "</svg>".len();
    (start < end).then(|| &text[start..end])
}

/// What a folder holds, by kind, names sorted; the page itself and lock files left out.
#[derive(Default)]
pub struct Outputs {
    pub charts: Vec<PathBuf>,
    pub pictures: Vec<PathBuf>,
    pub tables: Vec<PathBuf>,
    pub other: Vec<PathBuf>,
}

impl Outputs {
    pub fn of(dir: &Path) -> Outputs {
        let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|rd| rd.filter_map(|e| e.ok()).filter(|e| e.path().is_file()).map(|e| e.path()).collect())
            .unwrap_or_default();
        names.sort();
        let mut o = Outputs::default();
        for p in names {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_string();
            if name == super::PAGE_FILE || name.starts_with('.') || name.ends_with(".tmp") {
                continue;
            }
            match p.extension().and_then(|e| e.to_str()) {
                // A particle picture is shown by its PNG when there is one: its SVG holds a
                // circle per element, too heavy to inline.
                Some("svg") if is_picture(&p) && p.with_extension("png").is_file() => o.other.push(p),
                Some("svg") => o.charts.push(p),
                Some("png") if p.with_extension("svg").is_file() && !is_picture(&p.with_extension("svg")) => {}
                // A movie (`d.movie_every`) is an animated picture.
                Some("png" | "gif") => o.pictures.push(p),
                Some("csv") => o.tables.push(p),
                _ => o.other.push(p),
            }
        }
        o
    }
}

/// Whether an SVG file is a particle picture (see `plot::picture::PICTURE_MARK`): read only
/// its first bytes.
fn is_picture(svg: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 512];
    let n = std::fs::File::open(svg).and_then(|mut f| f.read(&mut head)).unwrap_or(0);
    String::from_utf8_lossy(&head[..n]).contains(crate::plot::picture::PICTURE_MARK)
}

fn name_of(p: &Path) -> String {
    p.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_string()
}

/// The largest chart placed inline: the page holds every inline chart, so a chart of
/// millions of points (before charts were thinned, 500 MB) made the page as large again.
const MAX_INLINE_SVG: u64 = 2 << 20;

/// A chart too large to inline: its PNG when it has one (as an image), else a link.
fn linked_chart(svg: &Path, name: &str, bytes: u64) -> String {
    let size = format!("{:.1} MB, linked, not inlined", bytes as f64 / 1e6);
    let png = svg.with_extension("png");
    if png.is_file() {
        format!(
            "<figure><img src=\"{}\" alt=\"{}\"><figcaption><a href=\"{}\">{}</a> ({size})</figcaption></figure>\n",
            href(&name_of(&png)),
            escape(name),
            href(name),
            escape(name)
        )
    } else {
        format!("<p><a href=\"{}\">{}</a> ({size})</p>\n", href(name), escape(name))
    }
}

/// Charts inline (those under [`MAX_INLINE_SVG`]; larger ones linked), pictures as images,
/// tables (their first rows) and the other files, each under its heading when there is any.
pub fn output_sections(o: &Outputs, skip_tables: &[&str]) -> String {
    let mut s = String::new();
    if !o.charts.is_empty() {
        s.push_str("<h2>Charts</h2>\n");
        for p in &o.charts {
            let name = name_of(p);
            let bytes = std::fs::metadata(p).map_or(0, |m| m.len());
            if bytes > MAX_INLINE_SVG {
                s.push_str(&linked_chart(p, &name, bytes));
                continue;
            }
            let text = std::fs::read_to_string(p).unwrap_or_default();
            match inline_svg(&text) {
                Some(svg) => {
                    let _ = writeln!(
                        s,
                        "<figure>{svg}<figcaption><a href=\"{}\">{}</a></figcaption></figure>",
                        href(&name),
                        escape(&name)
                    );
                }
                None => {
                    let _ = writeln!(s, "<p><a href=\"{}\">{}</a> (not an SVG chart)</p>", href(&name), escape(&name));
                }
            }
        }
    }
    if !o.pictures.is_empty() {
        s.push_str("<h2>Pictures</h2>\n");
        for p in &o.pictures {
            let name = name_of(p);
            let _ = writeln!(
                s,
                "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
                href(&name),
                escape(&name),
                escape(&name)
            );
        }
    }
    let tables: Vec<&PathBuf> = o.tables.iter().filter(|p| !skip_tables.contains(&name_of(p).as_str())).collect();
    if !tables.is_empty() {
        s.push_str("<h2>Tables</h2>\n");
        for p in tables {
            let name = name_of(p);
            let _ = writeln!(s, "<h3><a href=\"{}\">{}</a></h3>", href(&name), escape(&name));
            s.push_str(&csv_table(&std::fs::read_to_string(p).unwrap_or_default(), 20));
        }
    }
    if !o.other.is_empty() {
        s.push_str("<h2>Other files</h2>\n<ul>\n");
        for p in &o.other {
            let name = name_of(p);
            let _ = writeln!(s, "<li><a href=\"{}\">{}</a></li>", href(&name), escape(&name));
        }
        s.push_str("</ul>\n");
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_and_href_make_hostile_names_inert() {
        assert_eq!(escape("<script>\"a\" & 'b'"), "&lt;script&gt;&quot;a&quot; &amp; &#39;b&#39;");
        assert_eq!(href("a b#c?.svg"), "a%20b%23c%3F.svg");
        assert_eq!(href("run01/index.html"), "run01/index.html");
    }

    #[test]
    fn inline_svg_drops_the_declaration_and_refuses_other_text() {
        let svg = "<?xml version=\"1.0\"?>\n<svg width=\"1\"><rect/></svg>\n";
        assert_eq!(inline_svg(svg), Some("<svg width=\"1\"><rect/></svg>"));
        assert_eq!(inline_svg("not a chart"), None);
    }

    #[test]
    fn csv_table_shows_the_first_rows_and_counts_the_rest() {
        let t = csv_table("a,b\n1,2\n3,4\n5,6\n", 2);
        assert!(t.contains("<th>a</th><th>b</th>") && t.contains("<td>3</td>") && !t.contains("<td>5</td>"));
        assert!(t.contains("1 more row(s)"));
    }
}
