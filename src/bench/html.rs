//! `index.html` of a bench: the settings, the table (medians, and every run when there are
//! several), the error-against-time plot, and the reference, each integrator's image and its
//! false-colour error image side by side, with a colour bar. Every link is relative (the page
//! works offline, from the output directory) and the page is well-formed XML (XHTML
//! polyglot), so tests and tools can parse it back.

use super::colormap::{LOG10_MAX, LOG10_MIN, STOPS};
use super::report::{COLUMNS, Row};
use std::fmt::Write as _;

/// What the page shows; paths are relative to the page.
pub struct Page<'a> {
    pub scene: &'a str,
    /// Settings line (time, runs, seeds, threads, crop, reference).
    pub settings: &'a str,
    pub medians: &'a [Row],
    /// Per-run rows (shown when there are several runs).
    pub runs: &'a [Row],
    pub plot: &'a str,
    pub reference_png: &'a str,
    /// (integrator, image PNG, error PNG, EXR) per integrator, in table order.
    pub images: &'a [(String, String, String, String)],
}

/// Escape text for XML content and attribute values.
pub fn escape(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for ch in text.chars() {
        match ch {
            '&' => s.push_str("&amp;"),
            '<' => s.push_str("&lt;"),
            '>' => s.push_str("&gt;"),
            '"' => s.push_str("&quot;"),
            '\'' => s.push_str("&#39;"),
            c => s.push(c),
        }
    }
    s
}

const STYLE: &str = "body{font-family:sans-serif;margin:1.5em;color:#222}\
table{border-collapse:collapse;margin:1em 0}\
th,td{border:1px solid #bbb;padding:.25em .6em;text-align:right;white-space:nowrap}\
th:nth-child(-n+3),td:nth-child(-n+3){text-align:left}\
.grid{display:flex;flex-wrap:wrap;gap:1em}\
figure{margin:0}figure img{image-rendering:pixelated;width:256px;display:block}\
figcaption{font-size:.85em;max-width:256px}\
.bar{width:256px;height:14px}.barlabels{display:flex;justify-content:space-between;width:256px;font-size:.8em}";

/// The page as text.
pub fn page(p: &Page) -> String {
    let mut s = String::new();
    let title = format!("lodestar bench: {}", p.scene);
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html xmlns=\"http://www.w3.org/1999/xhtml\" lang=\"en\">\n<head>\n\
         <meta charset=\"utf-8\"/>\n<title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
        escape(&title)
    );
    let _ = writeln!(s, "<h1>{}</h1>", escape(&title));
    let _ = writeln!(s, "<p class=\"settings\">{}</p>", escape(p.settings));
    let _ = writeln!(
        s,
        "<p>Data: <a href=\"report.csv\">report.csv</a>, <a href=\"curves.csv\">curves.csv</a>. \
         Speed-up: MSE of the first integrator over this one's, at equal time.</p>"
    );
    table(&mut s, "summary", p.scene, p.medians);
    if p.runs.len() > p.medians.len() {
        let _ = writeln!(s, "<h2>Every run</h2>");
        table(&mut s, "runs", p.scene, p.runs);
    }
    let _ = writeln!(
        s,
        "<h2>Error against time</h2>\n<p><img class=\"plot\" src=\"{}\" alt=\"MSE against seconds, log-log\"/></p>",
        escape(p.plot)
    );
    let _ = writeln!(s, "<h2>Images (first run)</h2>\n<div class=\"grid\">");
    figure(&mut s, p.reference_png, "reference", "reference");
    for (name, png, _, exr) in p.images {
        let caption = format!("{} (<a href=\"{}\">EXR</a>)", escape(name), escape(exr));
        figure_raw(&mut s, png, &format!("{name} image"), &caption);
    }
    let _ = writeln!(
        s,
        "</div>\n<h2>Relative squared error</h2>\n<div class=\"grid\">"
    );
    for (name, _, err, _) in p.images {
        figure(&mut s, err, &format!("{name} error"), name);
    }
    let stops: Vec<String> = STOPS
        .iter()
        .map(|c| format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]))
        .collect();
    let _ = writeln!(
        s,
        "</div>\n<p>Per pixel (a - r)² / (r² + 0.01), mean over channels, log scale:</p>\n\
         <div class=\"bar\" style=\"background:linear-gradient(to right,{})\"></div>\n\
         <div class=\"barlabels\"><span>1e{LOG10_MIN} or less</span><span>1e{LOG10_MAX} or more</span></div>",
        stops.join(",")
    );
    s.push_str("</body>\n</html>\n");
    s
}

fn table(s: &mut String, class: &str, scene: &str, rows: &[Row]) {
    let _ = write!(s, "<table class=\"{class}\">\n<tr>");
    for c in COLUMNS {
        let _ = write!(s, "<th>{}</th>", escape(c));
    }
    s.push_str("</tr>\n");
    for r in rows {
        s.push_str("<tr>");
        for cell in r.cells(scene) {
            let _ = write!(s, "<td>{}</td>", escape(&cell));
        }
        s.push_str("</tr>\n");
    }
    s.push_str("</table>\n");
}

fn figure(s: &mut String, src: &str, alt: &str, caption: &str) {
    figure_raw(s, src, alt, &escape(caption));
}

/// A figure whose caption is already XHTML.
fn figure_raw(s: &mut String, src: &str, alt: &str, caption_xhtml: &str) {
    let _ = writeln!(
        s,
        "<figure><img src=\"{}\" alt=\"{}\"/><figcaption>{caption_xhtml}</figcaption></figure>",
        escape(src),
        escape(alt)
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup() {
        assert_eq!(
            escape("a<b & \"c\" 'd'>"),
            "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;"
        );
    }
}
