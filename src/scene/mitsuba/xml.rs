//! Reading Mitsuba XML into an owned element tree: `<include>` files spliced in place,
//! `<default>` parameters (overridden by `-D`) substituted for `$name` in attributes,
//! `<path>` search folders, and the typed values of plugin parameters. Every element
//! keeps its file, line and column for error messages.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::rc::Rc;

use crate::scene::format::TransformOp;
pub use crate::scene::values::Loc;
use crate::{Error, Result};

/// Largest XML file read, in bytes.
pub const MAX_XML_BYTES: u64 = 64 << 20;
/// Deepest element nesting accepted (real scenes nest a handful of levels).
pub const MAX_NESTING: usize = 64;
/// Deepest chain of includes.
pub const MAX_INCLUDE_DEPTH: usize = 16;
/// Most elements over all files (roxmltree's own node limit guards each file too).
pub const MAX_ELEMENTS: usize = 1 << 20;

/// An element with its attributes (after `$` substitution) and child elements.
#[derive(Clone, Debug)]
pub struct El {
    /// Tag name.
    pub tag: String,
    /// Attributes in document order.
    pub attrs: Vec<(String, String)>,
    /// Child elements (includes spliced in).
    pub kids: Vec<El>,
    /// Where it starts.
    pub loc: Loc,
    /// Folder of the file it is in (relative file names start there).
    pub dir: Rc<PathBuf>,
}

impl El {
    /// An attribute's value.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(k, _)| k == name).map(|(_, v)| v.as_str())
    }

    /// A required attribute.
    pub fn need(&self, name: &str) -> Result<&str> {
        self.attr(name).ok_or_else(|| self.loc.err(format!("<{}> lacks the `{name}` attribute", self.tag)))
    }

    /// `<tag type="...">` as written in messages.
    pub fn what(&self) -> String {
        match self.attr("type") {
            Some(t) => format!("<{} type=\"{t}\">", self.tag),
            None => format!("<{}>", self.tag),
        }
    }

    /// A number attribute.
    pub fn num(&self, name: &str) -> Result<Option<f64>> {
        self.attr(name).map(|v| parse_f64(v).map_err(|e| self.loc.err(format!("attribute `{name}`: {e}")))).transpose()
    }
}

fn parse_f64(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("`{s}` is not a number"))?;
    if !v.is_finite() || v.abs() > f32::MAX as f64 {
        return Err(format!("`{s}` is not a finite number"));
    }
    Ok(v)
}

/// Numbers separated by commas and/or spaces, as Mitsuba writes vectors and matrices.
pub fn parse_list(s: &str) -> std::result::Result<Vec<f64>, String> {
    s.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).map(parse_f64).collect()
}

/// The whole document: the root's children, the search folders and the parameters.
pub struct Tree {
    /// The `<scene>` element, includes spliced in.
    pub root: El,
    /// Folders from `<path value>` (in order), then the main file's folder.
    pub search: Vec<PathBuf>,
    /// The files `<include>`d, as read.
    pub includes: Vec<PathBuf>,
}

struct Reader {
    params: BTreeMap<String, String>,
    /// Parameter names some `$name` used (an unused `-D` is refused, as Mitsuba does).
    used: BTreeSet<String>,
    /// Names of `<default>` parameters, for the message about an unused `-D`.
    declared: BTreeSet<String>,
    /// Where each object `id` was first given: ids are one namespace over all files.
    ids: BTreeMap<String, Loc>,
    /// Canonical paths of the files being read, outermost first (include cycles).
    stack: Vec<PathBuf>,
    search: Vec<PathBuf>,
    includes: Vec<PathBuf>,
    elements: usize,
}

/// Reads `path` and everything it includes. `defines` are `-D name=value` settings,
/// which win over the file's `<default>` values. A `-D` name that no `$name` uses is
/// an error naming it and the scene's parameters: Mitsuba 3's parser refuses unused
/// parameters too (`ParserConfig::unused_parameters`, an error by default), and a
/// typo (`-D sp=4` for `$spp`) would otherwise change nothing silently. An object `id`
/// given twice is an error naming both places, as in Mitsuba ("duplicate id").
pub fn read(path: &Path, defines: &[(String, String)]) -> Result<Tree> {
    let mut r = Reader {
        params: defines.iter().cloned().collect(),
        used: BTreeSet::new(),
        declared: BTreeSet::new(),
        ids: BTreeMap::new(),
        stack: Vec::new(),
        search: Vec::new(),
        includes: Vec::new(),
        elements: 0,
    };
    let root = r.file(path, None)?;
    for (name, value) in defines {
        if !r.used.contains(name) {
            let known: BTreeSet<&str> = r.used.iter().chain(&r.declared).map(String::as_str).collect();
            let known: Vec<&str> = known.into_iter().collect();
            return Err(Error::input(format!(
                "{}: -D `{name}={value}`: the scene uses no `${name}` (its parameters: {})",
                path.display(),
                if known.is_empty() { "none".to_string() } else { known.join(", ") }
            )));
        }
    }
    let mut search = r.search;
    search.push(path.parent().map(Path::to_path_buf).unwrap_or_default());
    Ok(Tree { root, search, includes: r.includes })
}

/// Finds a file named in the scene: absolute, or relative to the folder of the file
/// that names it, then to each search folder. Errors list where it looked.
pub fn resolve(name: &str, from: &Path, search: &[PathBuf], loc: &Loc) -> Result<PathBuf> {
    let p = Path::new(name);
    if p.is_absolute() {
        return Ok(p.to_path_buf());
    }
    let mut tried = vec![from.to_path_buf()];
    tried.extend(search.iter().rev().cloned());
    for dir in &tried {
        let c = dir.join(p);
        if c.exists() {
            return Ok(c);
        }
    }
    // A scene in the working folder has the empty folder: shown as `.`, each folder once.
    let mut dirs: Vec<String> = Vec::new();
    for d in &tried {
        let shown = if d.as_os_str().is_empty() { "`.`".to_string() } else { format!("`{}`", d.display()) };
        if !dirs.contains(&shown) {
            dirs.push(shown);
        }
    }
    Err(loc.err(format!("file `{name}` not found (looked in {})", dirs.join(", "))))
}

impl Reader {
    fn file(&mut self, path: &Path, at: Option<&Loc>) -> Result<El> {
        let name = path.display().to_string();
        let fail = |msg: String| match at {
            Some(l) => l.err(msg),
            None => Error::input(format!("scene `{name}`: {msg}")),
        };
        let meta = std::fs::metadata(path).map_err(|e| fail(format!("cannot read `{name}`: {e}")))?;
        if !meta.is_file() {
            return Err(fail(format!("`{name}` is not a regular file")));
        }
        if meta.len() > MAX_XML_BYTES {
            return Err(fail(format!("`{name}` is {} bytes; XML scenes are limited to {MAX_XML_BYTES}", meta.len())));
        }
        let canon = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        if self.stack.contains(&canon) {
            return Err(fail(format!("`{name}` includes itself (through {} files)", self.stack.len())));
        }
        if self.stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(fail(format!("includes nest deeper than {MAX_INCLUDE_DEPTH} files")));
        }
        let text = match crate::scene::text::read_text(path) {
            Ok(text) => text,
            // Not UTF-8: the error says where in the file; an include also says who named it.
            Err(Error::Input(msg)) => return Err(at.map_or(Error::Input(msg.clone()), |l| l.err(msg))),
            Err(e) => return Err(e),
        };
        let opts =
            roxmltree::ParsingOptions { allow_dtd: false, nodes_limit: MAX_ELEMENTS as u32, ..Default::default() };
        let doc = roxmltree::Document::parse_with_options(&text, opts).map_err(|e| {
            let p = e.pos();
            let hint = if matches!(e, roxmltree::Error::DtdDetected) {
                " (a DOCTYPE, and with it entity definitions, is not accepted in scene files)"
            } else {
                ""
            };
            Error::input(format!("{name}:{}:{}: malformed XML: {e}{hint}", p.row, p.col))
        })?;
        let file = Rc::new(name.clone());
        let dir = Rc::new(path.parent().map(Path::to_path_buf).unwrap_or_default());
        let root = doc.root_element();
        let loc = |n: roxmltree::Node| {
            let p = doc.text_pos_at(n.range().start);
            Loc { file: file.clone(), line: p.row, col: p.col }
        };
        if root.tag_name().name() != "scene" {
            return Err(loc(root).err(format!("the root element is <{}>, not <scene>", root.tag_name().name())));
        }
        let version =
            root.attribute("version").ok_or_else(|| loc(root).err("<scene> lacks the `version` attribute"))?;
        let major = version.split('.').next().and_then(|m| m.trim().parse::<u32>().ok());
        match major {
            Some(2) | Some(3) => {}
            Some(0) | Some(1) => {
                return Err(loc(root).err(format!(
                    "scene version {version}: wavetrace reads Mitsuba 2.x and 3.x files. Older files use other \
                     parameter names (camelCase such as `toWorld`, `intIOR`); Mitsuba 3 upgrades them as it loads \
                     them (its XML parser's upgrade step). Rewrite the file with version=\"3.0.0\" and the \
                     snake_case names (`to_world`, `int_ior`, ...)"
                )))
            }
            _ => return Err(loc(root).err(format!("scene version `{version}` is not 2.x or 3.x"))),
        }
        self.stack.push(canon);
        let mut top = self.element(root, &loc, &dir, 0)?;
        self.stack.pop();
        top.attrs.retain(|(k, _)| k != "version");
        Ok(top)
    }

    fn element<'a>(
        &mut self,
        node: roxmltree::Node<'a, 'a>,
        loc: &dyn Fn(roxmltree::Node) -> Loc,
        dir: &Rc<PathBuf>,
        depth: usize,
    ) -> Result<El> {
        let here = loc(node);
        if depth > MAX_NESTING {
            return Err(here.err(format!("elements nest deeper than {MAX_NESTING} levels")));
        }
        self.elements += 1;
        if self.elements > MAX_ELEMENTS {
            return Err(here.err(format!("more than {MAX_ELEMENTS} elements")));
        }
        let mut attrs = Vec::new();
        for a in node.attributes() {
            attrs.push((a.name().to_string(), self.substitute(a.value(), &here)?));
        }
        let tag = node.tag_name().name();
        // `<ref id>` and `<alias id>` name an object; every other `id` defines one.
        if let Some((_, id)) = attrs.iter().find(|(k, _)| k == "id").filter(|_| tag != "ref" && tag != "alias") {
            if let Some(first) = self.ids.get(id) {
                return Err(here.err(format!(
                    "<{tag}> has duplicate id \"{id}\" (first given at {}:{}:{})",
                    first.file, first.line, first.col
                )));
            }
            self.ids.insert(id.clone(), here.clone());
        }
        let mut el =
            El { tag: node.tag_name().name().to_string(), attrs, kids: Vec::new(), loc: here, dir: dir.clone() };
        for child in node.children().filter(|c| c.is_element()) {
            let kid = self.element(child, loc, dir, depth + 1)?;
            match kid.tag.as_str() {
                "default" => {
                    let name = kid.need("name")?.to_string();
                    let value = kid.need("value")?.to_string();
                    self.declared.insert(name.clone());
                    self.params.entry(name).or_insert(value);
                }
                "path" => {
                    let v = kid.need("value")?;
                    self.search.push(dir.join(v));
                }
                "include" => {
                    let name = kid.need("filename")?;
                    let mut search = self.search.clone();
                    search.extend(self.stack.first().and_then(|p| p.parent()).map(Path::to_path_buf));
                    let path = resolve(name, dir, &search, &kid.loc)?;
                    self.includes.push(path.clone());
                    let inc = self.file(&path, Some(&kid.loc))?;
                    el.kids.extend(inc.kids);
                }
                _ => el.kids.push(kid),
            }
        }
        Ok(el)
    }

    /// Where an unset `$name` is in an include, or in a file made to be included: which
    /// file includes it, or which files in its folder do (one of those is the scene to
    /// render, and it sets the parameter).
    fn include_hint(&self, name: &str) -> String {
        let file_name = |p: &Path| p.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let Some(here) = self.stack.last() else { return String::new() };
        if let [.., outer, _] = self.stack.as_slice() {
            return format!(
                "; `{}` is included by `{}`, which sets no `${name}` before it",
                file_name(here),
                file_name(outer)
            );
        }
        let includers = includers(here);
        if includers.is_empty() {
            return String::new();
        }
        let list: Vec<String> = includers.iter().map(|n| format!("`{n}`")).collect();
        format!(
            "; `{}` is meant to be included: {} include{} it and set its parameters, render {}",
            file_name(here),
            list.join(", "),
            if list.len() == 1 { "s" } else { "" },
            if list.len() == 1 { "that scene" } else { "one of those" }
        )
    }

    /// Replaces `$name` with the parameter's value; an unknown name is an error.
    fn substitute(&mut self, v: &str, loc: &Loc) -> Result<String> {
        if !v.contains('$') {
            return Ok(v.to_string());
        }
        let mut out = String::new();
        let mut rest = v;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let tail = &rest[i + 1..];
            let end = tail.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(tail.len());
            let name = &tail[..end];
            let value = self.params.get(name).cloned().ok_or_else(|| {
                let known: Vec<&str> = self.params.keys().map(String::as_str).collect();
                loc.err(format!(
                    "`${name}` has no value: no <default name=\"{name}\"> before it and no -D {name}=... (known: {}){}",
                    if known.is_empty() { "none".to_string() } else { known.join(", ") },
                    self.include_hint(name)
                ))
            })?;
            out.push_str(&value);
            self.used.insert(name.to_string());
            rest = &tail[end..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

/// The names of the XML files beside `file` that `<include>` it by its name (the first
/// 100 files of the folder looked at, each up to [`MAX_XML_BYTES`]).
fn includers(file: &Path) -> Vec<String> {
    let (Some(dir), Some(name)) = (file.parent(), file.file_name().and_then(|n| n.to_str())) else {
        return Vec::new();
    };
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut found: Vec<String> = entries
        .flatten()
        .take(100)
        .map(|e| e.path())
        .filter(|p| p != file && p.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml")))
        .filter(|p| std::fs::metadata(p).is_ok_and(|m| m.is_file() && m.len() <= MAX_XML_BYTES))
        .filter(|p| {
            std::fs::read_to_string(p)
                .is_ok_and(|t| t.contains(&format!("filename=\"{name}\"")) || t.contains(&format!("filename='{name}'")))
        })
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    found.sort();
    found
}

/// A typed parameter value.
#[derive(Clone, Debug)]
pub enum Value {
    /// `<float>`, `<integer>`, or a `<spectrum>`/`<rgb>` with one number.
    Num(f64),
    /// `<rgb>` (three numbers) or a constant `<spectrum>`.
    Rgb([f64; 3]),
    /// `<point>` or `<vector>`.
    Vec([f64; 3]),
    /// `<boolean>`.
    Bool(bool),
    /// `<string>`.
    Str(String),
    /// `<transform>`: the steps in order.
    Transform(Vec<TransformOp>),
}

/// The tags of parameter elements.
pub const VALUE_TAGS: [&str; 8] = ["float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector"];

fn vec3_of(el: &El, default: f64) -> Result<[f64; 3]> {
    if let Some(v) = el.attr("value") {
        let l = parse_list(v).map_err(|e| el.loc.err(e))?;
        return match l[..] {
            [x] => Ok([x; 3]),
            [x, y, z] => Ok([x, y, z]),
            _ => Err(el.loc.err(format!("{}: expected 1 or 3 numbers in `{v}`", el.what()))),
        };
    }
    Ok([el.num("x")?.unwrap_or(default), el.num("y")?.unwrap_or(default), el.num("z")?.unwrap_or(default)])
}

fn f32s(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// The value of parameter element `el` (`<float name=... value=...>` and the others).
pub fn value(el: &El) -> Result<Value> {
    let bad = |e: String| el.loc.err(format!("<{} name=\"{}\">: {e}", el.tag, el.attr("name").unwrap_or("")));
    Ok(match el.tag.as_str() {
        "float" | "integer" => Value::Num(parse_f64(el.need("value")?).map_err(bad)?),
        "boolean" => match el.need("value")? {
            "true" => Value::Bool(true),
            "false" => Value::Bool(false),
            v => return Err(bad(format!("`{v}` is not true or false"))),
        },
        "string" => Value::Str(el.need("value")?.to_string()),
        "rgb" | "spectrum" => {
            if el.attr("filename").is_some() || el.need("value")?.contains(':') {
                return Err(bad(
                    "spectra given as wavelength:value lists or files are not supported; give an <rgb> or one number"
                        .into(),
                ));
            }
            let l = parse_list(el.need("value")?).map_err(bad)?;
            match l[..] {
                [x] => Value::Num(x),
                [r, g, b] if el.tag == "rgb" => Value::Rgb([r, g, b]),
                _ => return Err(bad(format!("expected {} numbers", if el.tag == "rgb" { "1 or 3" } else { "1" }))),
            }
        }
        "point" | "vector" => Value::Vec(vec3_of(el, 0.0)?),
        "transform" => Value::Transform(transform(el)?),
        _ => return Err(bad("not a parameter".into())),
    })
}

fn lookat_vec(el: &El, name: &str) -> Result<[f32; 3]> {
    let v = el.need(name)?;
    match parse_list(v).map_err(|e| el.loc.err(e))?[..] {
        [x, y, z] => Ok(f32s([x, y, z])),
        _ => Err(el.loc.err(format!("<lookat>: `{name}` needs 3 numbers"))),
    }
}

/// The steps of a `<transform>` element, in document order.
pub fn transform(el: &El) -> Result<Vec<TransformOp>> {
    let mut ops = Vec::new();
    for k in &el.kids {
        ops.push(match k.tag.as_str() {
            "translate" => TransformOp::Translate(f32s(vec3_of(k, 0.0)?)),
            "scale" => TransformOp::Scale(f32s(vec3_of(k, 1.0)?)),
            "rotate" => {
                let axis = vec3_of(k, 0.0)?;
                let angle = k.num("angle")?.ok_or_else(|| k.loc.err("<rotate> lacks the `angle` attribute"))?;
                TransformOp::Rotate { axis: f32s(axis), angle: angle as f32 }
            }
            "matrix" => {
                let v = parse_list(k.need("value")?).map_err(|e| k.loc.err(e))?;
                match v.len() {
                    16 => TransformOp::Matrix(v.iter().map(|&x| x as f32).collect()),
                    // A 3×3 matrix is the linear part.
                    9 => TransformOp::Matrix(
                        [v[0], v[1], v[2], 0.0, v[3], v[4], v[5], 0.0, v[6], v[7], v[8], 0.0, 0.0, 0.0, 0.0, 1.0]
                            .iter()
                            .map(|&x| x as f32)
                            .collect(),
                    ),
                    n => return Err(k.loc.err(format!("<matrix> has {n} numbers; expected 16 (or 9)"))),
                }
            }
            "lookat" => TransformOp::Lookat {
                origin: lookat_vec(k, "origin")?,
                target: lookat_vec(k, "target")?,
                up: if k.attr("up").is_some() { lookat_vec(k, "up")? } else { [0.0, 1.0, 0.0] },
            },
            other => {
                return Err(k
                    .loc
                    .err(format!("<{other}> in a <transform>: expected translate, rotate, scale, matrix or lookat")))
            }
        });
    }
    Ok(ops)
}
