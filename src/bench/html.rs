//! `index.html` of a bench: the settings, the table (medians, and every run when there are
//! several), the error-against-time plot, an image comparison (any two of the reference and
//! the integrators' images at the same crop and zoom, by a slider or by flipping, with their
//! error maps beside them), and the reference, each integrator's image and its false-colour
//! error image side by side, with a colour bar. Every link is relative (the page works
//! offline, from the output directory, with no external resource) and the page is
//! well-formed XML (XHTML polyglot), so tests and tools can parse it back.

use super::colormap::{LOG10_MAX, LOG10_MIN, STOPS};
use super::report::{COLUMNS, Row};
use std::fmt::Write as _;

/// What the page shows; paths are relative to the page.
pub struct Page<'a> {
    /// The scene file.
    pub scene: &'a str,
    /// Settings line (time, runs, seeds, threads, crop, reference).
    pub settings: &'a str,
    /// One row of medians per integrator.
    pub medians: &'a [Row],
    /// Per-run rows (shown when there are several runs).
    pub runs: &'a [Row],
    /// The error-against-time plot (SVG).
    pub plot: &'a str,
    /// The reference image's PNG.
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
.bar{width:256px;height:14px}.barlabels{display:flex;justify-content:space-between;width:256px;font-size:.8em}\
.cmp-row{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start}\
.cmp-view{position:relative;overflow:auto;max-width:100%;max-height:80vh;cursor:pointer;border:1px solid #bbb}\
.cmp-view img,.cmp-err img{image-rendering:pixelated;display:block;max-width:none}\
#cmp-a-clip{position:absolute;left:0;top:0;height:100%;overflow:hidden;border-right:2px solid #fff}\
#cmp-slider{width:256px}";

/// The comparison widget's behaviour: `E` lists the images (`png`, `err`: error map or
/// empty, `name`) in the order of the two selectors; the top image (A) is clipped to the
/// slider's share of the width in slide mode, shown or hidden by a click or the space bar in
/// flip mode; both are drawn at the same size (zoom) inside one scrolling view, so any crop
/// is the same for both.
const COMPARE_JS: &str = r#"(function () {
  var $ = function (id) { return document.getElementById(id); };
  var E = JSON.parse($('cmp-data').textContent);
  var a = $('cmp-a'), b = $('cmp-b'), slider = $('cmp-slider'), zoom = $('cmp-zoom');
  var showA = true;
  function mode() { return $('cmp-mode-flip').checked ? 'flip' : 'slide'; }
  function setErr(img, cap, e) {
    img.style.visibility = e.err ? 'visible' : 'hidden';
    if (e.err) { img.src = e.err; }
    cap.textContent = e.err ? e.name + ': error' : e.name + ': (no error map)';
  }
  function update() {
    var ea = E[a.value], eb = E[b.value], w = (256 * Number(zoom.value)) + 'px';
    $('cmp-a-img').src = ea.png; $('cmp-b-img').src = eb.png;
    [$('cmp-a-img'), $('cmp-b-img'), $('cmp-err-a'), $('cmp-err-b')].forEach(function (i) { i.style.width = w; });
    $('cmp-view').style.width = w;
    setErr($('cmp-err-a'), $('cmp-err-a-cap'), ea);
    setErr($('cmp-err-b'), $('cmp-err-b-cap'), eb);
    var slide = mode() === 'slide';
    slider.disabled = !slide;
    $('cmp-a-clip').style.width = slide ? slider.value + '%' : (showA ? '100%' : '0%');
    $('cmp-shown').textContent = slide
      ? ea.name + ' left of the line, ' + eb.name + ' right of it'
      : 'showing ' + (showA ? ea.name : eb.name) + ' (click the image or press space to flip)';
  }
  function flip() { if (mode() === 'flip') { showA = !showA; update(); } }
  [a, b, zoom, $('cmp-mode-slide'), $('cmp-mode-flip')].forEach(function (el) { el.addEventListener('change', update); });
  slider.addEventListener('input', update);
  $('cmp-view').addEventListener('click', flip);
  document.addEventListener('keydown', function (ev) {
    if (ev.key === ' ' && mode() === 'flip') { ev.preventDefault(); flip(); }
  });
  update();
})();"#;

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
    compare(&mut s, p);
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

/// The image comparison: two selectors (A: the first integrator, B: the reference), slide or
/// flip, zoom, the view and the two error maps; its data as JSON and its script.
fn compare(s: &mut String, p: &Page) {
    let mut entries = vec![(
        "reference".to_string(),
        p.reference_png.to_string(),
        String::new(),
    )];
    entries.extend(
        p.images
            .iter()
            .map(|(name, png, err, _)| (name.clone(), png.clone(), err.clone())),
    );
    let json: Vec<String> = entries
        .iter()
        .map(|(n, png, err)| {
            format!(
                "{{\"name\":{},\"png\":{},\"err\":{}}}",
                json_string(n),
                json_string(png),
                json_string(err)
            )
        })
        .collect();
    let options = |selected: usize| -> String {
        entries
            .iter()
            .enumerate()
            .map(|(i, (n, _, _))| {
                let sel = if i == selected {
                    " selected=\"selected\""
                } else {
                    ""
                };
                format!("<option value=\"{i}\"{sel}>{}</option>", escape(n))
            })
            .collect()
    };
    let a = if entries.len() > 1 { 1 } else { 0 };
    let (first_png, first_err) = (&entries[a].1, &entries[a].2);
    let _ = writeln!(
        s,
        "<h2>Compare</h2>\n<div class=\"compare\">\n<p>A <select id=\"cmp-a\">{}</select> \
         B <select id=\"cmp-b\">{}</select> \
         <label><input type=\"radio\" name=\"cmp-mode\" id=\"cmp-mode-slide\" checked=\"checked\"/> slide</label> \
         <label><input type=\"radio\" name=\"cmp-mode\" id=\"cmp-mode-flip\"/> flip</label> \
         zoom <select id=\"cmp-zoom\"><option value=\"1\">1x</option><option value=\"2\" selected=\"selected\">2x</option>\
         <option value=\"4\">4x</option><option value=\"8\">8x</option></select></p>\n\
         <p><input type=\"range\" id=\"cmp-slider\" min=\"0\" max=\"100\" value=\"50\"/> <span id=\"cmp-shown\"></span></p>\n\
         <div class=\"cmp-row\">\n<div class=\"cmp-view\" id=\"cmp-view\">\
         <img id=\"cmp-b-img\" src=\"{}\" alt=\"image B\"/>\
         <div id=\"cmp-a-clip\"><img id=\"cmp-a-img\" src=\"{}\" alt=\"image A\"/></div></div>\n\
         <figure class=\"cmp-err\"><img id=\"cmp-err-a\" src=\"{}\" alt=\"error map of A\"/><figcaption id=\"cmp-err-a-cap\"></figcaption></figure>\n\
         <figure class=\"cmp-err\"><img id=\"cmp-err-b\" src=\"{}\" alt=\"error map of B\"/><figcaption id=\"cmp-err-b-cap\"></figcaption></figure>\n\
         </div>\n</div>\n<script type=\"application/json\" id=\"cmp-data\">[{}]</script>\n\
         <script>//<![CDATA[\n{COMPARE_JS}\n//]]></script>",
        options(a),
        options(0),
        escape(p.reference_png),
        escape(first_png),
        // Until the script runs, both error slots show A's map (the reference has none).
        escape(if first_err.is_empty() {
            p.reference_png
        } else {
            first_err
        }),
        escape(if first_err.is_empty() {
            p.reference_png
        } else {
            first_err
        }),
        json.join(",")
    );
}

/// A JSON string literal (quotes, backslashes and control characters escaped; `<` and `&`
/// too, so the text is safe inside a script element of an XHTML page).
fn json_string(text: &str) -> String {
    let mut out = String::from("\"");
    for ch in text.chars() {
        match ch {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 || c == '<' || c == '>' || c == '&' => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
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
    fn json_strings_are_escaped_for_a_script_element() {
        assert_eq!(
            json_string("a\"b\\c<d>&\n"),
            "\"a\\\"b\\\\c\\u003cd\\u003e\\u0026\\u000a\""
        );
    }

    #[test]
    fn escapes_markup() {
        assert_eq!(
            escape("a<b & \"c\" 'd'>"),
            "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;"
        );
    }
}
