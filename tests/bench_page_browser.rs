//! The bench page as a reader sees it, in a real browser (headless Chromium): a tiny bench is
//! run, then `index.html` is loaded (inside a harness page that inspects it once loaded) and
//! checked for: the summary table with one row per integrator, the error-against-time plot
//! drawn, every image loaded (none broken), no console message (errors included), every link
//! and source pointing at a file that exists, and the comparison widget working (slider,
//! flip, choice of images with their error maps, zoom). A deliberately broken copy of the page
//! (one image link renamed) must fail the same checks.
//!
//! Needs `chromium` (Debian's package). Without it the test says so and passes, unless
//! `LODESTAR_REQUIRE_BROWSER=1` (set by `.ci/run`, which installs Chromium), when it fails.

use std::path::{Path, PathBuf};
use std::process::Command;

fn chromium() -> Option<PathBuf> {
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|name| {
            let o = Command::new("sh")
                .args(["-c", &format!("command -v {name}")])
                .output()
                .ok()?;
            let p = String::from_utf8_lossy(&o.stdout).trim().to_string();
            (o.status.success() && !p.is_empty()).then(|| PathBuf::from(p))
        })
}

/// The harness: loads `page` in an iframe, exercises the widget, and writes one `key value`
/// line per finding into `<pre id="out">`.
const HARNESS: &str = r#"<!DOCTYPE html>
<html><body><pre id="out">pending</pre>
<iframe id="f" src="PAGE" width="1400" height="1000"></iframe>
<script>
var out = [];
function say(k, v) { out.push(k + ' ' + v); }
function fire(el, type) { el.dispatchEvent(new Event(type, { bubbles: true })); }
document.getElementById('f').onload = function () {
  var d = document.getElementById('f').contentDocument;
  try {
    say('summary_rows', d.querySelectorAll('table.summary tr').length);
    var plot = d.querySelector('img.plot');
    say('plot', plot ? plot.naturalWidth : -1);
    var $ = function (id) { return d.getElementById(id); };
    var src = function (id) { return $(id).getAttribute('src'); };
    say('start', $('cmp-a-clip').style.width + ' ' + src('cmp-a-img') + ' ' + src('cmp-b-img'));
    $('cmp-slider').value = 20; fire($('cmp-slider'), 'input');
    say('slide20', $('cmp-a-clip').style.width);
    $('cmp-mode-flip').checked = true; fire($('cmp-mode-flip'), 'change');
    say('flip', $('cmp-a-clip').style.width);
    $('cmp-view').click();
    say('flipped', $('cmp-a-clip').style.width + ' ' + $('cmp-shown').textContent);
    $('cmp-b').value = '2'; fire($('cmp-b'), 'change');
    say('b', src('cmp-b-img') + ' ' + src('cmp-err-b'));
    $('cmp-zoom').value = '4'; fire($('cmp-zoom'), 'change');
    say('zoom', $('cmp-view').style.width);
  } catch (e) { say('exception', e); }
  setTimeout(function () {
    var broken = [];
    for (var i = 0; i < d.images.length; i++) {
      var im = d.images[i];
      if (im.style.visibility !== 'hidden' && (!im.complete || im.naturalWidth === 0)) broken.push(im.getAttribute('src'));
    }
    say('images', d.images.length);
    say('broken', broken.length ? broken.join(',') : 'none');
    document.getElementById('out').textContent = out.join('\n');
  }, 1000);
};
</script></body></html>
"#;

struct Findings {
    lines: Vec<String>,
    console: Vec<String>,
}

impl Findings {
    fn get(&self, key: &str) -> String {
        self.lines
            .iter()
            .find_map(|l| l.strip_prefix(&format!("{key} ")))
            .unwrap_or_else(|| panic!("no '{key}' in {:?}", self.lines))
            .to_string()
    }
}

fn inspect(browser: &Path, dir: &Path, page: &str) -> Findings {
    let harness = dir.join(format!("harness-{page}"));
    std::fs::write(&harness, HARNESS.replace("PAGE", page)).unwrap();
    let o = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--allow-file-access-from-files",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=8000",
            "--dump-dom",
        ])
        .arg(format!("file://{}", harness.display()))
        .output()
        .expect("cannot run chromium");
    let dom = String::from_utf8_lossy(&o.stdout);
    let text = dom
        .split("<pre id=\"out\">")
        .nth(1)
        .and_then(|t| t.split("</pre>").next())
        .unwrap_or_else(|| panic!("no harness output: {dom}"));
    let console = String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| l.contains(":CONSOLE") && l.contains(page))
        .map(str::to_string)
        .collect();
    Findings {
        lines: text.lines().map(|l| l.replace("&amp;", "&")).collect(),
        console,
    }
}

/// Every `src` and `href` of the page that names a file, missing ones listed.
fn missing_links(dir: &Path, page: &str) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join(page)).unwrap();
    let options = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(&text, options).unwrap();
    doc.descendants()
        .flat_map(|n| [n.attribute("src"), n.attribute("href")])
        .flatten()
        .filter(|l| !l.starts_with('#') && !l.contains("://"))
        .filter(|l| !dir.join(l).is_file())
        .map(str::to_string)
        .collect()
}

#[test]
fn the_bench_page_loads_and_its_comparison_works_in_a_browser() {
    let Some(browser) = chromium() else {
        assert!(
            std::env::var("LODESTAR_REQUIRE_BROWSER").as_deref() != Ok("1"),
            "LODESTAR_REQUIRE_BROWSER=1 but no chromium on PATH (apt-get install chromium)"
        );
        eprintln!("SKIPPED: no chromium on PATH (apt-get install chromium to run this test)");
        return;
    };
    let dir = std::env::temp_dir().join(format!("lodestar-page-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let exe = env!("CARGO_BIN_EXE_lodestar");
    let run = |args: &[&str]| {
        let o = Command::new(exe)
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    let reference = dir.join("ref.exr").display().to_string();
    let out = dir.join("bench");
    run(&[
        "render",
        "tests/data/tiny.toml",
        "--spp",
        "64",
        "--quiet",
        "-o",
        &reference,
    ]);
    run(&[
        "bench",
        "--scene",
        "tests/data/tiny.toml",
        "--integrators",
        "pt,bdpt",
        "--time",
        "0.2",
        "--runs",
        "2",
        "--threads",
        "1",
        "--quiet",
        "--reference",
        &reference,
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(missing_links(&out, "index.html"), Vec::<String>::new());
    let f = inspect(&browser, &out, "index.html");
    assert_eq!(f.console, Vec::<String>::new(), "console messages");
    assert_eq!(f.get("summary_rows"), "3", "header + 2 integrators");
    assert!(
        f.get("plot").parse::<i64>().unwrap() > 0,
        "the plot is not drawn"
    );
    assert_eq!(f.get("start"), "50% images/pt.png images/reference.png");
    assert_eq!(f.get("slide20"), "20%");
    assert_eq!(f.get("flip"), "100%");
    assert!(
        f.get("flipped").starts_with("0% showing reference"),
        "{}",
        f.get("flipped")
    );
    assert_eq!(f.get("b"), "images/bdpt.png images/bdpt.error.png");
    assert_eq!(f.get("zoom"), "1024px");
    assert!(f.get("images").parse::<u32>().unwrap() >= 9);
    assert_eq!(f.get("broken"), "none");
    assert!(
        f.lines.iter().all(|l| !l.starts_with("exception")),
        "{:?}",
        f.lines
    );

    // Control: the same page with one image link broken and a script error must fail.
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    let bad = page
        .replacen(
            "src=\"images/bdpt.error.png\"",
            "src=\"images/nothing.png\"",
            1,
        )
        .replacen("(function () {", "(function () { undefinedFunction();", 1);
    assert_ne!(bad, page);
    std::fs::write(out.join("broken.html"), bad).unwrap();
    assert_eq!(missing_links(&out, "broken.html"), ["images/nothing.png"]);
    let f = inspect(&browser, &out, "broken.html");
    assert!(
        f.get("broken").contains("images/nothing.png"),
        "{:?}",
        f.lines
    );
    assert!(
        f.console.iter().any(|l| l.contains("undefinedFunction")),
        "{:?}",
        f.console
    );
    std::fs::remove_dir_all(&dir).ok();
}
