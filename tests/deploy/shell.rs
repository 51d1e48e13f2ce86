//! The simple commands of a shell text (the scripts, the README's shell blocks, compose's
//! string commands), parsed by `brush-parser`, the parser of the brush shell: a maintained bash
//! parser that takes everything our scripts use (functions, `case`, `[[ ]]`, `(( ))`, arrays,
//! `$(...)`, `${VAR:-x}`, `${a[@]+"${a[@]}"}`, heredocs, `&&`/`||`, `&`, `exec`, line
//! continuations).
//!
//! A command's words come with quotes removed and expansions kept as written (`"$hevo" serve`
//! -> `$hevo`, `serve`), since what is checked is the command line as written, not one run.
//! Redirections and heredoc bodies are left out. Command and process substitutions are handed
//! back as texts to be parsed in turn, with the line they start on.

use brush_parser::ast;
use brush_parser::word::{WordPiece, WordPieceWithSource};
use brush_parser::{Parser, ParserOptions};

/// One simple command.
#[derive(Debug, Clone, PartialEq)]
pub struct SimpleCommand {
    /// Its words, the command's name first (assignments before it left out).
    pub words: Vec<String>,
    /// The line each word starts on (a word after a line continuation is on a later line).
    pub word_lines: Vec<usize>,
    /// The names assigned before the name (`HEVO_TOKEN=x exec ...`), or by an assignment alone.
    pub assignments: Vec<String>,
    /// The line it starts on.
    pub line: usize,
}

/// A parsed shell text.
#[derive(Debug, Default, Clone)]
pub struct Parsed {
    /// Its simple commands, in order, from inside functions, conditionals and loops too.
    pub commands: Vec<SimpleCommand>,
    /// The texts of its command and process substitutions, each with the line it starts on.
    pub substitutions: Vec<(String, usize)>,
}

fn options() -> ParserOptions {
    ParserOptions::default()
}

/// Parses `text`, whose first line is line `first_line` of its file.
pub fn parse(text: &str, first_line: usize) -> Result<Parsed, String> {
    let mut parser = Parser::new(std::io::BufReader::new(text.as_bytes()), &options());
    let program = parser
        .parse_program()
        .map_err(|e| format!("{e} (counting from line {first_line})"))?;
    let mut walker = Walker {
        offset: first_line.saturating_sub(1),
        newlines: text
            .chars()
            .enumerate()
            .filter(|(_, c)| *c == '\n')
            .map(|(at, _)| at)
            .collect(),
        out: Parsed::default(),
    };
    for list in &program.complete_commands {
        walker.list(list);
    }
    Ok(walker.out)
}

/// The words of the first simple command of `text` (compose's `command: "..."`).
pub fn first_command_words(text: &str) -> Option<Vec<String>> {
    parse(text, 1)
        .ok()?
        .commands
        .into_iter()
        .find(|c| !c.words.is_empty())
        .map(|c| c.words)
}

/// Names a shell text exports (`export A B=1`), at any depth but not in substitutions.
pub fn exported_names(text: &str) -> Result<Vec<String>, String> {
    let mut names = Vec::new();
    for command in parse(text, 1)?.commands {
        if command.words.first().is_some_and(|w| w == "export") {
            names.extend(command.assignments);
            for word in &command.words[1..] {
                if !word.starts_with('-') {
                    names.push(word.split('=').next().unwrap_or(word).to_string());
                }
            }
        }
    }
    Ok(names)
}

/// A word with quotes removed and expansions kept as written.
pub fn word_text(raw: &str) -> String {
    match brush_parser::word::parse(raw, &options()) {
        Ok(pieces) => {
            let mut text = String::new();
            pieces_text(raw, &pieces, &mut text);
            text
        }
        Err(_) => brush_parser::unquote_str(raw),
    }
}

fn pieces_text(raw: &str, pieces: &[WordPieceWithSource], text: &mut String) {
    for piece in pieces {
        let source = raw
            .get(piece.start_index..piece.end_index)
            .unwrap_or_default();
        match &piece.piece {
            WordPiece::Text(s) | WordPiece::SingleQuotedText(s) | WordPiece::AnsiCQuotedText(s) => {
                text.push_str(s)
            }
            WordPiece::DoubleQuotedSequence(inner)
            | WordPiece::GettextDoubleQuotedSequence(inner) => pieces_text(raw, inner, text),
            WordPiece::EscapeSequence(s) => text.extend(s.chars().skip(1)),
            WordPiece::TildeExpansion(_)
            | WordPiece::ParameterExpansion(_)
            | WordPiece::CommandSubstitution(_)
            | WordPiece::BackquotedCommandSubstitution(_)
            | WordPiece::ArithmeticExpression(_) => text.push_str(source),
        }
    }
}

/// The command substitutions in a word (also inside `"..."` and `${VAR:-...}`), each with the
/// number of lines before it in the word.
fn word_substitutions(raw: &str) -> Vec<(String, usize)> {
    fn walk(
        raw: &str,
        pieces: &[WordPieceWithSource],
        base: usize,
        out: &mut Vec<(String, usize)>,
    ) {
        for piece in pieces {
            let lines_before = base
                + raw
                    .get(..piece.start_index)
                    .map_or(0, |s| s.matches('\n').count());
            match &piece.piece {
                WordPiece::CommandSubstitution(inner)
                | WordPiece::BackquotedCommandSubstitution(inner) => {
                    out.push((inner.clone(), lines_before));
                }
                WordPiece::DoubleQuotedSequence(inner)
                | WordPiece::GettextDoubleQuotedSequence(inner) => walk(raw, inner, base, out),
                WordPiece::ParameterExpansion(expr) => {
                    // `${VAR:-$(cmd)}`: the operand is a word of its own.
                    if let Some(operand) = parameter_operand(expr) {
                        for (inner, lines) in word_substitutions(operand) {
                            out.push((inner, lines_before + lines));
                        }
                    }
                }
                WordPiece::ArithmeticExpression(expr) => {
                    for (inner, lines) in word_substitutions(&expr.value) {
                        out.push((inner, lines_before + lines));
                    }
                }
                _ => {}
            }
        }
    }
    let mut out = Vec::new();
    if let Ok(pieces) = brush_parser::word::parse(raw, &options()) {
        walk(raw, &pieces, 0, &mut out);
    }
    out
}

fn parameter_operand(expr: &brush_parser::word::ParameterExpr) -> Option<&str> {
    use brush_parser::word::ParameterExpr as P;
    match expr {
        P::UseDefaultValues { default_value, .. }
        | P::AssignDefaultValues { default_value, .. } => default_value.as_deref(),
        P::IndicateErrorIfNullOrUnset { error_message, .. } => error_message.as_deref(),
        P::UseAlternativeValue {
            alternative_value, ..
        } => alternative_value.as_deref(),
        P::ReplaceSubstring { replacement, .. } => replacement.as_deref(),
        _ => None,
    }
}

struct Walker {
    /// Added to the text's 1-based line numbers.
    offset: usize,
    /// The character index of each newline of the text.
    newlines: Vec<usize>,
    out: Parsed,
}

impl Walker {
    /// The line a word starts on, from the (character) index its span starts at: brush-parser
    /// 0.4 gives a word that follows a line continuation the line number of the line above.
    fn line_of(&self, word: &ast::Word) -> Option<usize> {
        word.loc.as_ref().map(|loc| self.line_at(loc.start.index))
    }

    /// The line of the character at `index`.
    fn line_at(&self, index: usize) -> usize {
        self.newlines.partition_point(|&at| at < index) + 1 + self.offset
    }

    fn list(&mut self, list: &ast::CompoundList) {
        for ast::CompoundListItem(and_or, _) in &list.0 {
            self.pipeline(&and_or.first);
            for next in &and_or.additional {
                match next {
                    ast::AndOr::And(p) | ast::AndOr::Or(p) => self.pipeline(p),
                }
            }
        }
    }

    fn pipeline(&mut self, pipeline: &ast::Pipeline) {
        for command in &pipeline.seq {
            self.command(command);
        }
    }

    fn command(&mut self, command: &ast::Command) {
        match command {
            ast::Command::Simple(simple) => self.simple(simple),
            ast::Command::Compound(compound, redirects) => {
                self.compound(compound);
                self.redirects(redirects.as_ref());
            }
            ast::Command::Function(function) => {
                self.compound(&function.body.0);
                self.redirects(function.body.1.as_ref());
            }
            ast::Command::ExtendedTest(test, redirects) => {
                self.test_expr(&test.expr);
                self.redirects(redirects.as_ref());
            }
        }
    }

    fn compound(&mut self, compound: &ast::CompoundCommand) {
        use ast::CompoundCommand as C;
        match compound {
            C::Arithmetic(arithmetic) => self.arithmetic(&arithmetic.expr, None),
            C::ArithmeticForClause(clause) => {
                for expr in [&clause.initializer, &clause.condition, &clause.updater]
                    .into_iter()
                    .flatten()
                {
                    self.arithmetic(expr, None);
                }
                self.list(&clause.body.list);
            }
            C::BraceGroup(group) => self.list(&group.list),
            C::Subshell(subshell) => self.list(&subshell.list),
            C::ForClause(clause) => {
                for word in clause.values.iter().flatten() {
                    self.word_substitutions(word);
                }
                self.list(&clause.body.list);
            }
            C::CaseClause(clause) => {
                self.word_substitutions(&clause.value);
                for item in &clause.cases {
                    if let Some(list) = &item.cmd {
                        self.list(list);
                    }
                }
            }
            C::IfClause(clause) => {
                self.list(&clause.condition);
                self.list(&clause.then);
                for other in clause.elses.iter().flatten() {
                    if let Some(condition) = &other.condition {
                        self.list(condition);
                    }
                    self.list(&other.body);
                }
            }
            C::WhileClause(clause) | C::UntilClause(clause) => {
                self.list(&clause.0);
                self.list(&clause.1.list);
            }
            C::Coprocess(coprocess) => self.command(&coprocess.body),
        }
    }

    fn arithmetic(&mut self, expr: &ast::UnexpandedArithmeticExpr, line: Option<usize>) {
        let line = line.unwrap_or(self.offset + 1);
        for (inner, lines) in word_substitutions(&expr.value) {
            self.out.substitutions.push((inner, line + lines));
        }
    }

    fn test_expr(&mut self, expr: &ast::ExtendedTestExpr) {
        use ast::ExtendedTestExpr as E;
        match expr {
            E::And(a, b) | E::Or(a, b) => {
                self.test_expr(a);
                self.test_expr(b);
            }
            E::Not(a) | E::Parenthesized(a) => self.test_expr(a),
            E::UnaryTest(_, word) => self.word_substitutions(word),
            E::BinaryTest(_, left, right) => {
                self.word_substitutions(left);
                self.word_substitutions(right);
            }
        }
    }

    fn redirects(&mut self, redirects: Option<&ast::RedirectList>) {
        for redirect in redirects.iter().flat_map(|r| &r.0) {
            self.redirect(redirect);
        }
    }

    /// Redirection targets may hold substitutions (`>"$(mktemp)"`, `< <(cmd)`); heredoc bodies
    /// are left out.
    fn redirect(&mut self, redirect: &ast::IoRedirect) {
        match redirect {
            ast::IoRedirect::File(_, _, target) => match target {
                ast::IoFileRedirectTarget::Filename(word)
                | ast::IoFileRedirectTarget::Duplicate(word) => self.word_substitutions(word),
                ast::IoFileRedirectTarget::ProcessSubstitution(_, subshell) => {
                    self.list(&subshell.list)
                }
                ast::IoFileRedirectTarget::Fd(_) => {}
            },
            ast::IoRedirect::HereString(_, word) | ast::IoRedirect::OutputAndError(word, _) => {
                self.word_substitutions(word)
            }
            ast::IoRedirect::HereDocument(..) => {}
        }
    }

    fn word_substitutions(&mut self, word: &ast::Word) {
        self.word_substitutions_at(word, self.offset + 1);
    }

    /// As [`Walker::word_substitutions`], for a word that may have no location of its own
    /// (an assignment's value), which then starts on `line`.
    fn word_substitutions_at(&mut self, word: &ast::Word, line: usize) {
        let line = self.line_of(word).unwrap_or(line);
        for (inner, lines) in word_substitutions(&word.value) {
            self.out.substitutions.push((inner, line + lines));
        }
    }

    fn simple(&mut self, simple: &ast::SimpleCommand) {
        let mut command = SimpleCommand {
            words: Vec::new(),
            word_lines: Vec::new(),
            assignments: Vec::new(),
            line: 0,
        };
        let mut first_line: Option<usize> = None;
        let prefix = simple.prefix.iter().flat_map(|p| &p.0);
        let suffix = simple.suffix.iter().flat_map(|s| &s.0);
        let name = simple
            .word_or_name
            .iter()
            .map(|w| ast::CommandPrefixOrSuffixItem::Word(w.clone()));
        let items: Vec<ast::CommandPrefixOrSuffixItem> =
            prefix.cloned().chain(name).chain(suffix.cloned()).collect();
        for item in &items {
            match item {
                ast::CommandPrefixOrSuffixItem::Word(word) => {
                    let line = self.line_of(word);
                    first_line = first_line.or(line);
                    self.word_substitutions(word);
                    command.words.push(word_text(&word.value));
                    command
                        .word_lines
                        .push(line.or(first_line).unwrap_or(self.offset + 1));
                }
                ast::CommandPrefixOrSuffixItem::AssignmentWord(assignment, word) => {
                    let line = self
                        .line_of(word)
                        .unwrap_or_else(|| self.line_at(assignment.loc.start.index));
                    first_line = first_line.or(Some(line));
                    let name = match &assignment.name {
                        ast::AssignmentName::VariableName(name)
                        | ast::AssignmentName::ArrayElementName(name, _) => name.clone(),
                    };
                    match &assignment.value {
                        ast::AssignmentValue::Scalar(value) => {
                            self.word_substitutions_at(value, line)
                        }
                        ast::AssignmentValue::Array(values) => {
                            for (key, value) in values {
                                if let Some(key) = key {
                                    self.word_substitutions_at(key, line);
                                }
                                self.word_substitutions_at(value, line);
                            }
                        }
                    }
                    if command.words.is_empty() {
                        command.assignments.push(name);
                    } else {
                        // `export A=1`, `local x=$(...)`: an argument of the command.
                        command.words.push(word_text(&word.value));
                        command.word_lines.push(line);
                    }
                }
                ast::CommandPrefixOrSuffixItem::IoRedirect(redirect) => self.redirect(redirect),
                ast::CommandPrefixOrSuffixItem::ProcessSubstitution(_, subshell) => {
                    self.list(&subshell.list)
                }
            }
        }
        command.line = first_line.unwrap_or(self.offset + 1);
        self.out.commands.push(command);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(text: &str) -> Vec<(Vec<String>, usize)> {
        parse(text, 1)
            .unwrap()
            .commands
            .into_iter()
            .map(|c| (c.words, c.line))
            .collect()
    }

    #[test]
    fn quotes_go_and_expansions_stay() {
        assert_eq!(word_text(r#""$hevo""#), "$hevo");
        assert_eq!(word_text(r#"'a b'"c d"e\ f"#), "a bc de f");
        assert_eq!(word_text(r#""$(cat "$dir/url")""#), r#"$(cat "$dir/url")"#);
        assert_eq!(
            word_text(r#"${submit_args[@]+"${submit_args[@]}"}"#),
            r#"${submit_args[@]+"${submit_args[@]}"}"#
        );
        assert_eq!(word_text(r#""say \"hi\" \$x""#), r#"say "hi" $x"#);
    }

    #[test]
    fn commands_inside_functions_loops_and_conditionals_are_found() {
        let text = "f() {\n    local a=1 b\n    echo \"$a\"\n}\nfor i in 1 2; do\n    if [[ -n $i ]]; then run \"$i\" && ok; fi\ndone\ncase $x in\n    -h) usage ;;\nesac\nwhile ((n > 0)); do n=$((n - 1)); done\n";
        let found = words(text);
        let names: Vec<(&str, usize)> = found
            .iter()
            .map(|(w, l)| (w.first().map_or("", String::as_str), *l))
            .collect();
        assert_eq!(
            names,
            [
                ("local", 2),
                ("echo", 3),
                ("run", 6),
                ("ok", 6),
                ("usage", 9),
                ("", 11)
            ]
        );
        assert_eq!(found[0].0, ["local", "a=1", "b"]);
    }

    #[test]
    fn redirections_and_heredoc_bodies_are_left_out() {
        let text = "cat <<'EOF' >out\nhevo serve --not-a-command\nEOF\ncat <<-EOF\n\thevo also not\n\tEOF\nrun 2>&1 >\"$log\" arg &>/dev/null\n";
        let found = words(text);
        assert_eq!(
            found,
            [
                (vec!["cat".to_string()], 1),
                (vec!["cat".to_string()], 4),
                (vec!["run".to_string(), "arg".to_string()], 7)
            ]
        );
    }

    #[test]
    fn assignments_before_the_name_are_not_words() {
        let parsed = parse(
            "HEVO_TOKEN=x A=\"$(pwd)\" exec \"$bin/w\" --x \\\n    \"$y\"\nz=1\n",
            10,
        )
        .unwrap();
        assert_eq!(parsed.commands[0].words, ["exec", "$bin/w", "--x", "$y"]);
        assert_eq!(parsed.commands[0].word_lines, [10, 10, 10, 11]);
        assert_eq!(parsed.commands[0].assignments, ["HEVO_TOKEN", "A"]);
        assert_eq!(parsed.commands[0].line, 10);
        assert_eq!(parsed.commands[1].words, Vec::<String>::new());
        assert_eq!(parsed.commands[1].assignments, ["z"]);
        assert_eq!(parsed.commands[1].line, 12);
        assert_eq!(parsed.substitutions, [("pwd".to_string(), 10)]);
    }

    #[test]
    fn substitutions_are_found_with_their_lines() {
        let text = "job=$(\"$hevo\" submit --master \"$url\" \\\n    --token-file \"$t\")\necho \"http://${N:-$(hostname)}:${a##*:}\"\nfor _ in $(seq 1 3); do :; done\ndiff <(sort a) `ls`\n[[ -n $(id -u) ]]\nx=$(<\"$f\")\n";
        let parsed = parse(text, 1).unwrap();
        let subs: Vec<(&str, usize)> = parsed
            .substitutions
            .iter()
            .map(|(s, l)| (s.as_str(), *l))
            .collect();
        assert_eq!(
            subs,
            [
                // The line continuation is gone from the text.
                (
                    "\"$hevo\" submit --master \"$url\"     --token-file \"$t\"",
                    1
                ),
                ("hostname", 3),
                ("seq 1 3", 4),
                ("ls", 5),
                ("id -u", 6),
                ("<\"$f\"", 7)
            ]
        );
        // The process substitution is parsed with the command.
        assert!(parsed.commands.iter().any(|c| c.words == ["sort", "a"]));
    }

    #[test]
    fn exports_and_first_commands() {
        assert_eq!(
            exported_names(
                "export A B=1\nexport HOST_UID=$(id -u) HOST_GID=$(id -g)\nexport -n C\n"
            )
            .unwrap(),
            ["A", "B", "HOST_UID", "HOST_GID", "C"]
        );
        assert_eq!(
            first_command_words("hevo-worker --threads \"${WORKER_THREADS:-1}\""),
            Some(vec![
                "hevo-worker".to_string(),
                "--threads".to_string(),
                "${WORKER_THREADS:-1}".to_string()
            ])
        );
    }

    #[test]
    fn a_syntax_error_is_an_error() {
        assert!(parse("if true; then\n", 1).is_err());
        assert!(parse("echo \"unterminated\n", 1).is_err());
    }
}
