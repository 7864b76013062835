//! Prompt templates: one per approach and agent, shipped in `prompts/`,
//! overridable from a user folder, each identified by the hash of its text;
//! and the rendering of a G-PlanET table into the lines a model reads.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{sha256_hex, AgentError, AgentRole, Approach};

/// The templates shipped with the program, by file stem.
const BUILT_IN: [(&str, &str); 8] = [
    (
        "multi-image-skm",
        include_str!("../../prompts/multi-image-skm.txt"),
    ),
    (
        "multi-image-gkm",
        include_str!("../../prompts/multi-image-gkm.txt"),
    ),
    (
        "multi-image-planner",
        include_str!("../../prompts/multi-image-planner.txt"),
    ),
    (
        "single-image-single",
        include_str!("../../prompts/single-image-single.txt"),
    ),
    (
        "multi-table-skm",
        include_str!("../../prompts/multi-table-skm.txt"),
    ),
    (
        "multi-table-gkm",
        include_str!("../../prompts/multi-table-gkm.txt"),
    ),
    (
        "multi-table-planner",
        include_str!("../../prompts/multi-table-planner.txt"),
    ),
    (
        "single-table-single",
        include_str!("../../prompts/single-table-single.txt"),
    ),
];

/// The variables a template may use.
pub const VARIABLES: [&str; 5] = ["task", "table", "skm", "triples", "gkm"];

/// The file stem of the template for `role` in `approach`.
pub fn template_name(approach: Approach, role: AgentRole) -> String {
    format!("{}-{}", approach.name(), role.name())
}

/// The content hash of a template's text: which version of a prompt ran.
pub fn prompt_hash(text: &str) -> String {
    sha256_hex(text.as_bytes())[..16].to_string()
}

/// One prompt template: a system part and a user part with `{{variable}}`s.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Template {
    /// The file stem, e.g. `multi-image-skm`.
    pub name: String,
    /// Where it came from: a file, or `built-in`.
    pub source: String,
    /// The system prompt.
    pub system: String,
    /// The user prompt.
    pub user: String,
    /// The first 16 hex digits of the SHA-256 of the file's text: its version.
    pub hash: String,
}

impl Template {
    /// Parses a template file: a `[system]` line, the system prompt, a
    /// `[user]` line and the user prompt. Unknown variables are refused.
    pub fn parse(name: &str, source: &str, text: &str) -> Result<Self, AgentError> {
        let fail = |reason: String| AgentError::Prompt {
            name: format!("{name} ({source})"),
            reason,
        };
        let mut system = String::new();
        let mut user = String::new();
        let mut section: Option<&mut String> = None;
        let mut seen_user = false;
        for (number, line) in text.lines().enumerate() {
            match line.trim() {
                "[system]" => section = Some(&mut system),
                "[user]" => {
                    seen_user = true;
                    section = Some(&mut user);
                }
                _ => match section.as_deref_mut() {
                    Some(part) => {
                        part.push_str(line);
                        part.push('\n');
                    }
                    None if line.trim().is_empty() => {}
                    None => {
                        return Err(fail(format!(
                            "line {}: text before the first [system] or [user] line",
                            number + 1
                        )))
                    }
                },
            }
        }
        if !seen_user {
            return Err(fail(
                "no [user] section: add a line `[user]` before the user prompt".into(),
            ));
        }
        let template = Self {
            name: name.to_string(),
            source: source.to_string(),
            system: system.trim().to_string(),
            user: user.trim().to_string(),
            hash: prompt_hash(text),
        };
        for part in [&template.system, &template.user] {
            for variable in variables_in(part) {
                if !VARIABLES.contains(&variable.as_str()) {
                    return Err(fail(format!(
                        "unknown variable {{{{{variable}}}}}: use one of {}",
                        VARIABLES.join(", ")
                    )));
                }
            }
        }
        Ok(template)
    }

    /// The template as a file's text: a `[system]` section (when there is a
    /// system prompt) and a `[user]` section; [`Template::parse`] reads it
    /// back to the same prompts.
    pub fn text(&self) -> String {
        if self.system.is_empty() {
            format!("[user]\n{}", self.user)
        } else {
            format!("[system]\n{}\n\n[user]\n{}", self.system, self.user)
        }
    }

    /// The system and user prompts with `values` filled in (a variable
    /// without a value becomes empty).
    pub fn render(&self, values: &BTreeMap<&str, String>) -> (String, String) {
        (fill(&self.system, values), fill(&self.user, values))
    }
}

fn variables_in(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut rest = text;
    while let Some(start) = rest.find("{{") {
        let after = &rest[start + 2..];
        match after.find("}}") {
            Some(end) => {
                found.push(after[..end].trim().to_string());
                rest = &after[end + 2..];
            }
            None => break,
        }
    }
    found
}

fn fill(text: &str, values: &BTreeMap<&str, String>) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find("{{") {
        let after = &rest[start + 2..];
        let Some(end) = after.find("}}") else { break };
        out.push_str(&rest[..start]);
        if let Some(value) = values.get(after[..end].trim()) {
            out.push_str(value.trim());
        }
        rest = &after[end + 2..];
    }
    out.push_str(rest);
    out
}

/// Every template, by name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PromptSet {
    templates: BTreeMap<String, Template>,
}

impl PromptSet {
    /// The default user folder: `$XDG_CONFIG_HOME/mapvlm/prompts`, else
    /// `$HOME/.config/mapvlm/prompts`.
    pub fn default_dir() -> Option<PathBuf> {
        std::env::var_os("XDG_CONFIG_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".config")))
            .map(|base| base.join("mapvlm").join("prompts"))
    }

    /// The shipped templates, each replaced by `DIR/NAME.txt` where the user
    /// folder `dir` has one.
    pub fn load(dir: Option<&Path>) -> Result<Self, AgentError> {
        let mut templates = BTreeMap::new();
        for (name, text) in BUILT_IN {
            let user_file = dir.map(|d| d.join(format!("{name}.txt")));
            let template = match user_file.filter(|f| f.is_file()) {
                Some(file) => {
                    let text = std::fs::read_to_string(&file).map_err(|err| AgentError::Io {
                        path: file.clone(),
                        message: err.to_string(),
                    })?;
                    Template::parse(name, &file.display().to_string(), &text)?
                }
                None => Template::parse(name, "built-in", text)?,
            };
            templates.insert(name.to_string(), template);
        }
        Ok(Self { templates })
    }

    /// The template for `role` in `approach`.
    pub fn get(&self, approach: Approach, role: AgentRole) -> Result<&Template, AgentError> {
        let name = template_name(approach, role);
        self.templates.get(&name).ok_or(AgentError::Prompt {
            name,
            reason: "this agent does not take part in this approach".into(),
        })
    }

    /// The set with `template` in place of the one of the same name.
    pub fn with(mut self, template: Template) -> Self {
        self.templates.insert(template.name.clone(), template);
        self
    }

    /// The set with each template named in `texts` replaced by its text
    /// there (parsed; `source` names where the texts came from in errors),
    /// e.g. the workbench's edited prompts. Names of no template are left out.
    pub fn with_texts(
        mut self,
        texts: &BTreeMap<String, String>,
        source: &str,
    ) -> Result<Self, AgentError> {
        for (name, text) in texts {
            if self.templates.contains_key(name) {
                let template = Template::parse(name, source, text)?;
                self.templates.insert(name.clone(), template);
            }
        }
        Ok(self)
    }

    /// Every template.
    pub fn iter(&self) -> impl Iterator<Item = &Template> {
        self.templates.values()
    }
}

/// Renders a G-PlanET table (CSV: `id, object_type, position_x..z,
/// rotation_x..z, parent_receptacle`) as one line per object, receptacles
/// named rather than numbered: `Potato #2 at (0.19, 1.61, 2.10), in Fridge #83`.
pub fn render_table(path: &Path) -> Result<String, AgentError> {
    let fail = |reason: String| AgentError::Table {
        path: path.to_path_buf(),
        reason,
    };
    let bytes = crate::limits::read_file(path, crate::limits::MAX_TEXT_FILE_BYTES, "a table file")
        .map_err(|err| fail(err.to_string()))?;
    let text = String::from_utf8(bytes).map_err(|_| fail("not UTF-8 text".into()))?;
    let mut lines = text.lines().map(|l| l.trim_end_matches('\r'));
    let header: Vec<&str> = lines
        .next()
        .ok_or_else(|| fail("empty file: expected a G-PlanET CSV header".into()))?
        .split(',')
        .map(str::trim)
        .collect();
    let column = |name: &str| {
        header.iter().position(|h| *h == name).ok_or_else(|| {
            fail(format!("line 1: no `{name}` column; expected id, object_type, position_x..z, rotation_x..z, parent_receptacle"))
        })
    };
    let [id, kind, x, y, z, yaw, parent] = [
        column("id")?,
        column("object_type")?,
        column("position_x")?,
        column("position_y")?,
        column("position_z")?,
        column("rotation_y")?,
        column("parent_receptacle")?,
    ];
    struct Row {
        id: String,
        kind: String,
        position: Option<[f64; 3]>,
        yaw: String,
        parent: String,
    }
    let mut rows = Vec::new();
    for (index, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let number = index + 2;
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let cell = |i: usize| cells.get(i).copied().unwrap_or("");
        let coordinate = |i: usize| {
            cell(i).parse::<f64>().map_err(|_| {
                fail(format!(
                    "line {number}: `{}` in column {} is not a number",
                    cell(i),
                    header[i]
                ))
            })
        };
        let position = if [x, y, z].iter().all(|&i| cell(i).is_empty()) {
            None
        } else {
            Some([coordinate(x)?, coordinate(y)?, coordinate(z)?])
        };
        rows.push(Row {
            id: cell(id).to_string(),
            kind: cell(kind).to_string(),
            position,
            yaw: cell(yaw).to_string(),
            parent: cell(parent).to_string(),
        });
    }
    let names: BTreeMap<&str, String> = rows
        .iter()
        .map(|r| (r.id.as_str(), format!("{} #{}", r.kind, r.id)))
        .collect();
    let mut out = String::new();
    for row in &rows {
        let _ = write!(out, "{} #{}", row.kind, row.id);
        if let Some([px, py, pz]) = row.position {
            let _ = write!(out, " at ({px:.2}, {py:.2}, {pz:.2})");
        }
        if row.kind == "Agent" {
            let _ = write!(out, ", facing {}°", row.yaw);
        }
        if !row.parent.is_empty() {
            match names.get(row.parent.as_str()) {
                Some(name) => {
                    let _ = write!(out, ", in/on {name}");
                }
                None => {
                    let _ = write!(out, ", in/on #{}", row.parent);
                }
            }
        }
        out.push('\n');
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_templates_load_and_render() {
        let set = PromptSet::load(None).unwrap();
        let planner = set.get(Approach::MultiImage, AgentRole::Planner).unwrap();
        let values = BTreeMap::from([
            ("task", "Put a mug away".to_string()),
            ("triples", "(mug, on, table)".to_string()),
            ("gkm", "The mug is ahead.".to_string()),
        ]);
        let (_, user) = planner.render(&values);
        assert!(user.contains("Task: Put a mug away"));
        assert!(user.contains("(mug, on, table)"));
        assert!(!user.contains("{{"));
        assert!(set.get(Approach::SingleImage, AgentRole::Skm).is_err());
        for template in set.iter() {
            let back = Template::parse(&template.name, "text", &template.text()).unwrap();
            assert_eq!(
                (&back.system, &back.user),
                (&template.system, &template.user)
            );
        }
    }

    #[test]
    fn user_folder_overrides_and_unknown_variables_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("single-image-single.txt"),
            "[user]\nDo {{task}} now",
        )
        .unwrap();
        let set = PromptSet::load(Some(dir.path())).unwrap();
        let template = set.get(Approach::SingleImage, AgentRole::Single).unwrap();
        assert_eq!(template.user, "Do {{task}} now");
        assert_eq!(template.hash, sha256_hex(b"[user]\nDo {{task}} now")[..16]);
        std::fs::write(
            dir.path().join("single-image-single.txt"),
            "[user]\n{{colour}}",
        )
        .unwrap();
        let err = PromptSet::load(Some(dir.path())).unwrap_err().to_string();
        assert!(
            err.contains("single-image-single") && err.contains("colour"),
            "{err}"
        );
    }

    #[test]
    fn table_rows_name_their_receptacles() {
        let path = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../shared/data/alfred30/tables/trial_T20190907_200154_378982.csv"
        ));
        let rendered = render_table(path).unwrap();
        let first: Vec<&str> = rendered.lines().take(2).collect();
        assert_eq!(first[0], "Agent #0 at (1.25, 0.90, 1.00), facing 270°");
        assert!(
            first[1].starts_with("Vase #1 at (1.63, 1.66, -1.71), in/on "),
            "{}",
            first[1]
        );
        assert_eq!(rendered.lines().count(), 107);
        assert_eq!(rendered.lines().last(), Some("WestWall #106"));
    }
}
