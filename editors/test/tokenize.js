// Tokenizes every .tsl file given on the command line (or found under the
// directories given) with vscode-textmate and the grammar in
// editors/tsl.tmLanguage.json, and fails if a keyword, type, number, string
// or comment -- found independently here by simple regexes -- is left with
// only the base scope `source.tsl`, or outside comments and strings gets a
// scope of the wrong kind. Run through scripts/test-editor-grammar.sh.
const fs = require("fs");
const path = require("path");
const vsctm = require("vscode-textmate");
const oniguruma = require("vscode-oniguruma");

const root = path.resolve(__dirname, "..", "..");
const grammarPath = path.join(root, "editors", "tsl.tmLanguage.json");

// Keywords and types: the fixed alphabetic tokens of the lexer.
const lexer = fs.readFileSync(path.join(root, "src", "syntax", "lexer.rs"), "utf8");
const words = [...lexer.matchAll(/#\[token\("([A-Za-z_][A-Za-z0-9_]*)"\)\]/g)].map((m) => m[1]);
if (words.length < 10) throw new Error(`only ${words.length} keywords found in lexer.rs`);
// A type word may also name a method being defined (`normal normal() {...}`).
const kindOf = (w) => (w === "true" || w === "false" ? /^constant\.language/ : /^(keyword|storage|entity\.name\.function)\./);

function files(args) {
  const out = [];
  const walk = (p) => {
    if (fs.statSync(p).isDirectory()) {
      for (const e of fs.readdirSync(p).sort()) walk(path.join(p, e));
    } else if (p.endsWith(".tsl")) out.push(p);
  };
  args.forEach((a) => walk(path.resolve(root, a)));
  return out;
}

async function main() {
  const wasm = fs.readFileSync(require.resolve("vscode-oniguruma/release/onig.wasm")).buffer;
  await oniguruma.loadWASM(wasm);
  const registry = new vsctm.Registry({
    onigLib: Promise.resolve({
      createOnigScanner: (s) => new oniguruma.OnigScanner(s),
      createOnigString: (s) => new oniguruma.OnigString(s),
    }),
    loadGrammar: async (scope) =>
      scope === "source.tsl" ? vsctm.parseRawGrammar(fs.readFileSync(grammarPath, "utf8"), grammarPath) : null,
  });
  const grammar = await registry.loadGrammar("source.tsl");

  const list = files(process.argv.slice(2));
  let failures = 0;
  let checked = 0;
  for (const file of list) {
    const text = fs.readFileSync(file, "utf8");
    const lines = text.split("\n");
    // scopesAt[line][col] = the scope list of the token covering that column.
    const scopesAt = [];
    let state = vsctm.INITIAL;
    for (const line of lines) {
      const r = grammar.tokenizeLine(line, state);
      const cols = new Array(line.length);
      for (const t of r.tokens) for (let c = t.startIndex; c < Math.min(t.endIndex, line.length); c++) cols[c] = t.scopes;
      scopesAt.push(cols);
      state = r.ruleStack;
    }
    const starts = [0];
    for (const l of lines) starts.push(starts[starts.length - 1] + l.length + 1);
    const at = (off) => {
      let lo = 0;
      while (starts[lo + 1] <= off) lo++;
      return [lo, off - starts[lo]];
    };

    // Comments and strings, found by a simple scanner that knows the lexer's
    // rules (line comments, non-nesting block comments, one-line strings).
    const spans = []; // [start, end, kind]
    for (let i = 0; i < text.length; ) {
      if (text.startsWith("//", i)) {
        const e = text.indexOf("\n", i);
        spans.push([i, e < 0 ? text.length : e, "comment"]);
        i = e < 0 ? text.length : e;
      } else if (text.startsWith("/*", i)) {
        const e = text.indexOf("*/", i + 2);
        const end = e < 0 ? text.length : e + 2;
        spans.push([i, end, "comment"]);
        i = end;
      } else if (text[i] === '"') {
        let e = i + 1;
        while (e < text.length && text[e] !== '"' && text[e] !== "\n") e++;
        spans.push([i, Math.min(e + 1, text.length), "string"]);
        i = e + 1;
      } else i++;
    }
    const inSpan = (off) => spans.some(([s, e]) => off >= s && off < e);

    const check = (off, what, want) => {
      const [ln, col] = at(off);
      const scopes = scopesAt[ln][col] || ["source.tsl"];
      const inner = scopes.filter((s) => s !== "source.tsl");
      checked++;
      if (inner.length === 0 || !inner.some((s) => want.test(s))) {
        failures++;
        if (failures <= 50)
          console.log(`${path.relative(root, file)}:${ln + 1}:${col + 1}: ${what}: scopes ${scopes.join(" ")}`);
      }
    };

    for (const [s, , kind] of spans) {
      // Every character of the span that is not whitespace must be scoped.
      for (let o = s; o < spans.find((x) => x[0] === s)[1]; o++) {
        if (!/\s/.test(text[o])) {
          check(o, kind, kind === "comment" ? /^comment\./ : /^string\./);
        }
      }
    }
    const kw = new RegExp(`\\b(${words.join("|")})\\b`, "g");
    for (const m of text.matchAll(kw)) if (!inSpan(m.index)) check(m.index, `keyword \`${m[1]}\``, kindOf(m[1]));
    const num = /(?<![A-Za-z0-9_.])([0-9]+\.[0-9]+|\.[0-9]+|[0-9]+)([eE][+-]?[0-9]+)?(?![A-Za-z0-9_])/g;
    for (const m of text.matchAll(num)) {
      if (inSpan(m.index)) continue;
      for (let o = m.index; o < m.index + m[0].length; o++) check(o, `number \`${m[0]}\``, /^constant\.numeric\./);
    }
  }
  console.log(`${list.length} files, ${checked} characters checked, ${failures} failures`);
  if (list.length === 0) failures++;
  process.exit(failures ? 1 : 0);
}

main().catch((e) => {
  console.error(e);
  process.exit(2);
});
