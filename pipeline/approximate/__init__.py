"""`pipeline derive`: the cheapest accurate forms of a function a shader approximates, ranked by
compiled cycles per GPU architecture, in rooms by idea: the one kind of target, read and checked
once (`targets`); the search of forms (`search`: families by minimax, the grammar's search, the
templates, per-value fits and formulas of several variables, the kept cache); the measures
(`measures`: the error over the whole domain, bounds, execution, renders, fronts); the engines, one
per shape of target (`engines`); the outputs (`publishing`: files, page, shader export). `forms`
holds a found form and its printing; `api` the Python entry, `pipeline.derive`."""
