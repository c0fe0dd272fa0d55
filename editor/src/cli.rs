//! The command-line glue: `robosim lang run`, `robosim lang load`, `robosim edit`.

use crate::commands::{CommandError, Outcome, Picked, Prompt, VERBS, execute};
use crate::lang::LangError;
use crate::program::WriteLinksError;
use crate::robot::RobotError;
use crate::session::Editor;
use crate::structure::EditError;
use crate::{program, robot};
use robosim_instance_space::{Client, ClientError, Reader, ReaderError, Session};
use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Why `lang run`, `lang load` or `edit` stopped. A variant that wraps a lower error keeps it
/// (the variant itself for a transparent one, `source()` for the others); the message names the
/// program, directory, script line or session.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The command's input is wrong (the message names it).
    #[error("{0}")]
    Refused(String),
    /// A program or script could not be read (not a regular file, too large, unreadable).
    #[error(transparent)]
    Read(#[from] robosim_input::InputError),
    /// The program has an error (file:line:column).
    #[error(transparent)]
    Program(#[from] LangError),
    /// The program's link files were not written.
    #[error(transparent)]
    WriteLinks(#[from] WriteLinksError),
    /// A program's links belong to several robots (`program`: the program).
    #[error("{}: {source}", program.display())]
    Order {
        program: PathBuf,
        source: RobotError,
    },
    /// The link files do not make a robot.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// The session's keeper could not be reached or refused the transaction.
    #[error(transparent)]
    Client(#[from] ClientError),
    /// The session could not be read.
    #[error(transparent)]
    Reader(#[from] ReaderError),
    /// The editor could not start on the design or take up its history.
    #[error(transparent)]
    Edit(#[from] EditError),
    /// A line of an editor script was refused (`script`: the file, `line`: 1-based).
    #[error(
        "{}:{line}: {source} (this line changed nothing; the lines before it are committed)",
        script.display()
    )]
    Line {
        script: PathBuf,
        line: usize,
        source: CommandError,
    },
    /// The prompt's line editor failed.
    #[error(transparent)]
    Prompt(#[from] rustyline::error::ReadlineError),
}

impl From<String> for RunError {
    fn from(what: String) -> Self {
        RunError::Refused(what)
    }
}

impl From<&str> for RunError {
    fn from(what: &str) -> Self {
        RunError::Refused(what.to_owned())
    }
}

/// A ROBOSIM program's text: a regular file of at most [`robosim_input::Limit::TEXT`] bytes.
fn read_program(path: &Path) -> Result<String, RunError> {
    Ok(robosim_input::read_to_string(
        path,
        "a ROBOSIM program",
        robosim_input::Limit::TEXT,
    )?)
}

/// `robosim lang run PROGRAM --out DIR`: every STORE-LINK becomes a link file in DIR; a program
/// with an error writes none.
pub fn lang_run(program_path: &Path, out: &Path) -> Result<String, RunError> {
    let text = read_program(program_path)?;
    let o = program::run(&text, &program_path.display().to_string())?;
    if o.links.is_empty() {
        return Err(format!(
            "{}: the program stores no link (STORE-LINK)",
            program_path.display()
        )
        .into());
    }
    let paths = program::write_links(&o, out)?;
    let mut s = String::new();
    for v in &o.views {
        s.push_str(&format!("VIEW {v}\n"));
    }
    for (l, p) in o.links.iter().zip(&paths) {
        s.push_str(&format!(
            "{}: {} vectors, joints I {} / I+1 {}, mass {:.6} kg\n",
            p.display(),
            l.file.vectors.len(),
            l.file.joint_i.map_or('-', |j| j.letter()),
            l.file.joint_i1.map_or('-', |j| j.letter()),
            l.file.ainert[(3, 3)]
        ));
    }
    Ok(s)
}

/// `robosim lang run PROGRAM --as NAME [--out DIR]`: the program's links become robot NAME in
/// the session at once (one transaction), as `lang run` then `lang load` would make it; with
/// `--out` the link files are written too. A program with an error changes nothing.
pub fn lang_run_into(
    program_path: &Path,
    out: Option<&Path>,
    name: &str,
    session: &Session,
) -> Result<String, RunError> {
    let text = read_program(program_path)?;
    let o = program::run(&text, &program_path.display().to_string())?;
    let links: Vec<_> = o
        .links
        .iter()
        .map(|l| (l.name.clone(), l.file.clone()))
        .collect();
    if links.is_empty() {
        return Err(format!(
            "{}: the program stores no link (STORE-LINK)",
            program_path.display()
        )
        .into());
    }
    let (prefix, links) = robot::order_links(links).map_err(|source| RunError::Order {
        program: program_path.to_path_buf(),
        source,
    })?;
    let r = robot::from_links(links, name)?;
    let tx = robot::robot_transaction(&r, name)?;
    let mut written = String::new();
    if let Some(dir) = out {
        let paths = program::write_links(&o, dir)?;
        written = format!(
            "; wrote {}",
            paths
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let mut c = Client::connect(session, "lang-run")?;
    let a = c.transact(&tx)?;
    Ok(format!(
        "ran {} into session {}: {prefix} ({} links: {}) as robot {name}: {} joints, {} objects, version {}{written}",
        program_path.display(),
        session.name(),
        r.links.len(),
        r.links
            .iter()
            .map(|l| l.0.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        r.robot.joints.len(),
        a.created.len(),
        a.version
    ))
}

/// `robosim lang load DIR --as NAME [--robot PREFIX]`: the link files become a robot in the
/// session (one transaction).
pub fn lang_load(
    dir: &Path,
    name: &str,
    prefix: Option<&str>,
    session: &Session,
) -> Result<String, RunError> {
    let (prefix, paths) = robot::link_paths(dir, prefix)?;
    let r = robot::load_links(&paths, name)?;
    let tx = robot::robot_transaction(&r, name)?;
    let mut c = Client::connect(session, "lang-load")?;
    let a = c.transact(&tx)?;
    Ok(format!(
        "loaded {prefix} ({} links: {}) as robot {name}: {} joints, {} objects, version {}",
        r.links.len(),
        r.links
            .iter()
            .map(|l| l.0.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        r.robot.joints.len(),
        a.created.len(),
        a.version
    ))
}

/// Brings the prompt up to the session: the reader to at least `version` (the editor's own last
/// commit, so a relative move of a model object starts from the pose it wrote) and whatever
/// else arrived since (the change notifications); the model and the display's pick read from
/// it. A message when the pick changed.
pub fn follow<S: crate::session::Space>(
    reader: &mut Reader,
    ed: &Editor<S>,
    p: &mut Prompt,
    version: u64,
) -> Result<Option<String>, RunError> {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    loop {
        reader.refresh()?;
        if reader.snapshot().is_some_and(|s| s.version() >= version) {
            break;
        }
        if std::time::Instant::now() > deadline {
            return Err(
                format!("the session did not publish version {version} within 10 s").into(),
            );
        }
        reader.wait_change(std::time::Duration::from_millis(100))?;
    }
    let snap = reader.snapshot();
    let picked = snap.as_deref().and_then(|s| Picked::read(s, ed));
    let said = (picked != p.picked).then(|| match &picked {
        Some(k) => format!("picked: {}", k.describe()),
        None => "picked: nothing".to_owned(),
    });
    p.picked = picked;
    p.model = snap;
    Ok(said)
}

/// `robosim edit --robot NAME [--script FILE]`: resumes design NAME when the session holds one.
pub fn edit(session: &Session, robot: &str, script: Option<&Path>) -> Result<(), RunError> {
    let client = Client::connect(session, "edit")?;
    let mut reader = Reader::attach(session, "edit")?;
    let snap = reader.snapshot();
    let mut ed = match snap.as_deref() {
        Some(s) if crate::session::design_from_snapshot(s, robot).is_ok() => {
            Editor::resume(client, s, robot)?
        }
        _ => Editor::new(client, robot)?,
    };
    drop(snap);
    // The session's edits of this design are undoable here too (issue 39 item 5).
    let history = crate::session::history_path(&session.data_dir(), robot);
    match ed.keep_history(history)? {
        crate::session::HistoryFound::Taken { undo, redo } if undo + redo > 0 => eprintln!(
            "edit: design {robot}: {undo} edit(s) to undo and {redo} to redo from earlier editors of session {}",
            session.name()
        ),
        crate::session::HistoryFound::Stale => eprintln!(
            "edit: design {robot} was changed since its last editor kept its history: \
             that history is not taken up (undo starts from here)"
        ),
        _ => {}
    }
    let mut p = Prompt::default();
    match script {
        Some(path) => {
            let text = robosim_input::read_to_string(
                path,
                "an editor script",
                robosim_input::Limit::TEXT,
            )?;
            for (k, line) in text.lines().enumerate() {
                if let Some(said) = follow(&mut reader, &ed, &mut p, ed.version)? {
                    println!("{said}");
                }
                match execute(&mut ed, &mut p, line) {
                    Ok(Outcome::Quit) => break,
                    Ok(Outcome::Said(s)) => {
                        if !s.is_empty() {
                            println!("{s}");
                        }
                    }
                    Err(source) => {
                        return Err(RunError::Line {
                            script: path.to_path_buf(),
                            line: k + 1,
                            source,
                        });
                    }
                }
            }
            Ok(())
        }
        None => interactive(&mut ed, &mut p, &mut reader, session),
    }
}

struct Helper {
    names: Rc<RefCell<Vec<String>>>,
}

/// Completion at `pos` in `line`: a command for the first word, else an object name of
/// `names`, a polygon word (`top`, `bottom`), `to` or `selected`. The start of the word
/// completed and the candidates, in order.
pub fn complete(line: &str, pos: usize, names: &[String]) -> (usize, Vec<String>) {
    let pos = pos.min(line.len());
    if !line.is_char_boundary(pos) {
        return (pos, Vec::new());
    }
    let start = line[..pos]
        .rfind(|c: char| c.is_whitespace() || c == ',')
        .map_or(0, |i| i + 1);
    let word = &line[start..pos];
    let first = line[..start].trim().is_empty();
    let pool: Vec<String> = if first {
        VERBS.iter().map(|s| (*s).to_owned()).collect()
    } else {
        let mut v = names.to_vec();
        v.extend(["top", "bottom", "to", "selected"].map(str::to_owned));
        v
    };
    (
        start,
        pool.into_iter().filter(|c| c.starts_with(word)).collect(),
    )
}

impl rustyline::completion::Completer for Helper {
    type Candidate = String;
    fn complete(
        &self,
        line: &str,
        pos: usize,
        _ctx: &rustyline::Context<'_>,
    ) -> rustyline::Result<(usize, Vec<String>)> {
        Ok(complete(line, pos, &self.names.borrow()))
    }
}
impl rustyline::hint::Hinter for Helper {
    type Hint = String;
}
impl rustyline::highlight::Highlighter for Helper {}
impl rustyline::validate::Validator for Helper {}
impl rustyline::Helper for Helper {}

fn interactive(
    ed: &mut Editor<Client>,
    p: &mut Prompt,
    reader: &mut Reader,
    session: &Session,
) -> Result<(), RunError> {
    let names = Rc::new(RefCell::new(Vec::new()));
    let mut rl: rustyline::Editor<Helper, rustyline::history::FileHistory> =
        rustyline::Editor::new()?;
    rl.set_helper(Some(Helper {
        names: names.clone(),
    }));
    let hist = session.dir().join("edit-history.txt");
    let _ = rl.load_history(&hist);
    println!(
        "robosim edit: robot {}, link {} — `help` lists the commands, `quit` leaves",
        ed.design().robot,
        ed.design().link().name
    );
    loop {
        *names.borrow_mut() = ed
            .design()
            .link()
            .objects
            .iter()
            .map(|o| o.name.clone())
            .collect();
        // What the display picked since the last line (read at each prompt: a pick made while
        // a line is being typed shows at the next one).
        if let Some(said) = follow(reader, ed, p, ed.version)? {
            println!("{said}");
        }
        let prompt = format!(
            "{}.{}{}> ",
            ed.design().robot,
            ed.design().link().name,
            p.picked
                .as_ref()
                .map(|k| format!(" [{}]", k.name.as_deref().unwrap_or(&k.path)))
                .unwrap_or_default()
        );
        match rl.readline(&prompt) {
            Ok(line) => {
                if !line.trim().is_empty() {
                    let _ = rl.add_history_entry(line.as_str());
                }
                match execute(ed, p, &line) {
                    Ok(Outcome::Quit) => break,
                    Ok(Outcome::Said(s)) => {
                        if !s.is_empty() {
                            println!("{s}");
                        }
                    }
                    Err(e) => eprintln!("error: {e} (nothing changed)"),
                }
            }
            Err(rustyline::error::ReadlineError::Interrupted) => continue,
            Err(rustyline::error::ReadlineError::Eof) => break,
            Err(e) => return Err(e.into()),
        }
    }
    let _ = rl.save_history(&hist);
    Ok(())
}
