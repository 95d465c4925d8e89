-- The README's editor walk-through in a real editor: Neovim's own LSP client
-- (0.7 or newer, headless) talks to `tslc lsp` about a copy of
-- examples/texture_tree.tsl. Run by scripts/test-editor-nvim.sh, which sets
-- TSLC and TSL_FILE. Prints one "ok"/"FAIL" line per step and exits 1 on a failure.

local tslc, file = os.getenv("TSLC"), os.getenv("TSL_FILE")
local failures = 0
local function check(ok, what, detail)
  print((ok and "ok     " or "FAIL   ") .. what .. (detail and ("  (" .. detail .. ")") or ""))
  if not ok then failures = failures + 1 end
end
local function finish()
  print(string.format("nvim walk-through: %d failure(s)", failures))
  vim.cmd(failures == 0 and "qall!" or "cquit!")
end

vim.cmd("edit " .. vim.fn.fnameescape(file))
local buf = vim.api.nvim_get_current_buf()
vim.bo[buf].filetype = "tsl"
local client_id = vim.lsp.start_client({ name = "tsl", cmd = { tslc, "lsp" }, root_dir = vim.fn.fnamemodify(file, ":h") })
check(client_id ~= nil, "tslc lsp starts as Neovim's language server")
vim.lsp.buf_attach_client(buf, client_id)

local function wait(ms, pred) return vim.wait(ms, pred, 20) end
local function errors() return #vim.diagnostic.get(buf, { severity = vim.diagnostic.severity.ERROR }) end
local function client() return vim.lsp.get_client_by_id(client_id) end
-- A synchronous request at the first occurrence of `needle` (0-based line, byte column + offset).
local function request_at(method, needle, offset, extra)
  local lines = vim.api.nvim_buf_get_lines(buf, 0, -1, false)
  for i, line in ipairs(lines) do
    local col = line:find(needle, 1, true)
    if col then
      local params = vim.lsp.util.make_text_document_params(buf)
      params = { textDocument = params, position = { line = i - 1, character = col - 1 + (offset or 0) } }
      for k, v in pairs(extra or {}) do params[k] = v end
      local res = vim.lsp.buf_request_sync(buf, method, params, 5000)
      return res and res[client_id] and res[client_id].result, i
    end
  end
end

check(wait(10000, function() return client() and client().initialized end), "the server initializes")
-- 1. The clean file has no errors; a typo adds one as it is typed; undoing it clears it.
wait(1500, function() return false end)
check(errors() == 0, "the example checks clean", errors() .. " errors")
local line = vim.api.nvim_buf_get_lines(buf, 0, -1, false)
local n
for i, l in ipairs(line) do if l:find("material white", 1, true) then n = i break end end
local original = line[n]
vim.api.nvim_buf_set_lines(buf, n - 1, n, false, { "material white = lambert(kd: gray(1)" })
check(wait(5000, function() return errors() > 0 end), "an error appears as the edit is typed")
local d = vim.diagnostic.get(buf)[1]
check(d and d.lnum >= n - 1, "it is located at the edit", d and (d.lnum + 1 .. ":" .. d.col + 1 .. " " .. d.message))
vim.api.nvim_buf_set_lines(buf, n - 1, n, false, { original })
check(wait(5000, function() return errors() == 0 end), "and disappears when it is fixed")

-- 2. Hover over fbm shows its signature and documentation.
local hover = request_at("textDocument/hover", "fbm(P * 1.5", 1)
local text = hover and hover.contents and (hover.contents.value or vim.inspect(hover.contents)) or ""
check(text:find("fbm", 1, true) and #text > 80, "hover on fbm shows its documentation", text:gsub("\n", " "):sub(1, 90))

-- 3. Completion after `phong(` offers its parameters.
vim.api.nvim_buf_set_lines(buf, -1, -1, false, { "material trial = phong(" })
local last = vim.api.nvim_buf_line_count(buf)
local params = { textDocument = vim.lsp.util.make_text_document_params(buf), position = { line = last - 1, character = 23 } }
local res = vim.lsp.buf_request_sync(buf, "textDocument/completion", params, 5000)
local items = res and res[client_id] and res[client_id].result
items = items and (items.items or items) or {}
local labels = {}
for _, it in ipairs(items) do labels[it.label] = true end
check(labels["kd:"] or labels["kd"], "completion in phong( offers kd:", #items .. " items")
local sig = vim.lsp.buf_request_sync(buf, "textDocument/signatureHelp", params, 5000)
sig = sig and sig[client_id] and sig[client_id].result
check(sig and sig.signatures and #sig.signatures > 0 and sig.signatures[1].label:find("kd"), "signature help shows phong's parameters",
  sig and sig.signatures and sig.signatures[1] and sig.signatures[1].label)
vim.api.nvim_buf_set_lines(buf, last - 1, last, false, {})

-- 4. Go to definition of wood_rings lands in the prelude.
local def = request_at("textDocument/definition", "wood_rings(scale", 2)
local loc = def and (def[1] or def)
local uri = loc and (loc.uri or loc.targetUri) or ""
check(uri:find("%.tsl$") and not uri:find("texture_tree", 1, true), "definition of wood_rings is in the prelude", uri:match("[^/]*$"))

-- 5. Formatting returns edits that make the file canonical (a badly spaced line comes back).
vim.api.nvim_buf_set_lines(buf, n - 1, n, false, { "material   white=lambert( kd:gray(1) );" })
local fmt = vim.lsp.buf_request_sync(buf, "textDocument/formatting",
  { textDocument = vim.lsp.util.make_text_document_params(buf), options = { tabSize = 4, insertSpaces = true } }, 5000)
local edits = fmt and fmt[client_id] and fmt[client_id].result
if edits then vim.lsp.util.apply_text_edits(edits, buf, "utf-16") end
check(vim.api.nvim_buf_get_lines(buf, n - 1, n, false)[1] == original, "formatting restores the canonical line",
  vim.api.nvim_buf_get_lines(buf, n - 1, n, false)[1])

finish()
