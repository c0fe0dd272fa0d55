//! `robosim lang run|load`: the clap command ([`super::LangCmd`]) as the editor's plain one.

use robosim_editor::lang_cmd::LangCmd;

impl From<super::LangCmd> for LangCmd {
    fn from(c: super::LangCmd) -> Self {
        match c {
            super::LangCmd::Run { program, out, name } => LangCmd::Run { program, out, name },
            super::LangCmd::Load { dir, name, robot } => LangCmd::Load { dir, name, robot },
        }
    }
}
