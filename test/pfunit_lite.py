#!/usr/bin/env python3
"""pfunit_lite: run pFUnit 4 .pf test files without pFUnit.

Usage:  python3 test/pfunit_lite.py --out-dir DIR test/test_a.pf test/test_b.pf ...

Writes DIR/test_a.F90, DIR/test_b.F90, ... (the test modules with their @-directives translated
into calls of the module `funit`, test/lite/funit.f90) and DIR/pfunit_lite_main.F90, the main
program that runs every test.  Nothing is written if any input has an error; errors are reported
as "file:line: message" on stderr and the exit status is then 2.

Supported subset of pFUnit 4 (anything else starting with "@" is an error, so that no check is
silently dropped):

  module NAME ... use funit ... contains ... end module NAME     (NAME = base name of the file)
  @test       followed (after blank or comment lines only) by "subroutine NAME[()]"
  @before     likewise: called before every test of the module
  @after      likewise: called after every test of the module
  @assertEqual(expected, actual [, tolerance] [, message])
  @assertTrue(condition [, message])            @assertFalse(condition [, message])
  @assertLessThan(a, b [, message])             a < b
  @assertLessThanOrEqual(a, b [, message])      a <= b
  @assertGreaterThan(a, b [, message])          a > b
  @assertGreaterThanOrEqual(a, b [, message])   a >= b
  @assertIsFinite(x [, message])

Directive names are case-insensitive, as in pFUnit.  The arguments of an assertion are passed
unchanged, so the keyword forms tolerance= and message= work as written.  Which argument types
are accepted is decided by the generic interfaces of test/lite/funit.f90 at compile time.

Rejected as well, because genuine pFUnit 4 (its preprocessor funitproc and the compilation of
its output) rejects them, so that a suite accepted here also builds under real pFUnit
(make check PFUNIT_DIR=...; see doc/pfunit.md):

  - a directive continued with "&": funitproc recognises a directive only when it is complete
    on one line and copies a continued one unchanged, which the compiler then rejects;
  - a module procedure, module variable or derived type named like a public name of pFUnit's
    module funit (FUNIT_PUBLIC_NAMES, e.g. "run"): every test module does "use funit", so the
    name would clash with the use-associated one;
  - an assertion whose translation by funitproc, "  call assertXxx(<arguments>, &", is longer
    than 132 characters (gfortran's free-form limit).

Each assertion becomes

    #line N "file.pf"
    call funit_assert_xxx(<arguments>, location='file.pf:N')
    if (funit_failed()) return
    #line N+k "file.pf"

so compiler messages and backtraces point into the .pf file, and a test returns at its first
failed assertion, as with pFUnit.  All other lines are copied unchanged (@test/@before/@after
lines become comments), and generated lines are wrapped to at most 132 columns.
"""

import argparse
import os
import re
import sys

MAX_LINE = 132          # gfortran -ffree-line-length-132
MAX_EXPRESSION = 100    # characters of an assertTrue/False condition quoted in failure messages

# directive (lower case) -> (funit procedure, minimum number of operands, quote the condition)
ASSERTIONS = {
    'assertequal': ('funit_assert_equal', 2, False),
    'asserttrue': ('funit_assert_true', 1, True),
    'assertfalse': ('funit_assert_false', 1, True),
    'assertlessthan': ('funit_assert_less_than', 2, False),
    'assertlessthanorequal': ('funit_assert_less_than_or_equal', 2, False),
    'assertgreaterthan': ('funit_assert_greater_than', 2, False),
    'assertgreaterthanorequal': ('funit_assert_greater_than_or_equal', 2, False),
    'assertisfinite': ('funit_assert_is_finite', 1, False),
}
ANNOTATIONS = ('test', 'before', 'after')
# Keywords that the translator itself passes to funit.
RESERVED_KEYWORDS = ('location', 'expression')

# The public names of pFUnit 4.14's module funit (lower case).  Obtained from the gfortran module
# file PFUNIT-4.14/include/funit.mod of the genuine install (/work/shared/pfunit): the names of its
# generic interfaces (third section of the file) and of its symbol tree (last section), which
# gfortran writes for public entities only, leaving out compiler-generated names ("__...").
# Checked with gfortran 12: a module that does "use funit" and defines a procedure of any of
# these names does not compile ("already ... from module funit"); other names, e.g.
# assertIsMemberOf, do.
FUNIT_PUBLIC_NAMES = frozenset("""
abstractmatcher abstracttestparameter all_of allof any_of anyexceptions anyof array_with_size
assert_that assertall assertany assertequal assertexceptionraised assertfail assertfalse
assertgreaterthan assertgreaterthanorequal assertisfinite assertisnan assertlessthan
assertlessthanorequal assertnone assertnotall assertnotequal assertrelativelyequal
assertsameshape asserttrue basetestrunner catch catchnext contains_string debuglistener disable
empty_array ends_with equal_to every every_item expectation false fhamcrest finalize funit
generic_run get_context ignore_all ignore_differences initialize is isarraywithsize isequal
isnear isnot iso_fortran_env isrelativelynear istrueorfalse keep_all listenerpointer
loadtests_interface matchable matcherdescription namefilter near not output_unit
parallelcontext parameterizedtestcase predicate relatively_near remoterunner resultprinter
robustrunner run serialcontext sourcelocation starts_with stringcontains stringdescription
stringendswith stringstartswith stub subject taplistener test testannotation testcase
testlistener testlistenervector testmethod testresult testrunner testsuite throw
timeoutannotation trim_all true wascalled wascalledonce wasnotcalled whitespaceoptions
xmlprinter
""".split())

MODULE_RE = re.compile(r'^\s*module\s+(\w+)\s*$', re.IGNORECASE)
# "module NAME ! comment": a module statement that pFUnit's parser would not recognise.
MODULE_COMMENT_RE = re.compile(r'^\s*module\s+(?!procedure\b)(\w+)\s*!', re.IGNORECASE)
USE_FUNIT_RE = re.compile(r'^\s*use\s*(?:::\s*)?funit\b(.*)$', re.IGNORECASE)
SUBROUTINE_RE = re.compile(r'^\s*subroutine\s+(\w+)\s*(\([^)]*\))?\s*(!.*)?$', re.IGNORECASE)
KEYWORD_RE = re.compile(r'^\s*([A-Za-z]\w*)\s*=(?!=)')
# For the scope of module-level names: procedure statements (with an optional prefix and type),
# their end statements, interface blocks and derived-type definitions.
PROC_START_RE = re.compile(
    r'^\s*(?:(?:pure|impure|elemental|recursive|non_recursive|module)\s+)*'
    r'(?:(?:integer|real|logical|complex|character|double\s*precision|type|class)\s*'
    r'(?:\((?:[^()]|\([^()]*\))*\))?\s*(?:(?:pure|impure|elemental|recursive|non_recursive)\s+)*)?'
    r'(subroutine|function)\s+(\w+)', re.IGNORECASE)
PROC_END_RE = re.compile(r'^\s*end\s*(?:(?:subroutine|function)\b|$|!)', re.IGNORECASE)
INTERFACE_RE = re.compile(r'^\s*(?:abstract\s+)?interface\b', re.IGNORECASE)
END_INTERFACE_RE = re.compile(r'^\s*end\s*interface\b', re.IGNORECASE)
TYPE_DEF_RE = re.compile(r'^\s*type\s*(?:,[^:]*)?(?:::)?\s*(\w+)\s*(?:\(.*\))?\s*(?:!.*)?$', re.IGNORECASE)
END_TYPE_RE = re.compile(r'^\s*end\s*type\b', re.IGNORECASE)
CONTAINS_RE = re.compile(r'^\s*contains\s*(?:!.*)?$', re.IGNORECASE)
# statements with "::" that declare no new entity
NOT_DECLARATION_RE = re.compile(r'^\s*(?:use|public|private|protected|save|import|procedure\s*::)\b',
                                re.IGNORECASE)
# pFUnit's funitproc: the assertion directives it recognises (a whole line) and the first line
# it writes for one, "  call assert<name>(<arguments>, &"
FUNITPROC_ASSERT_RE = re.compile(r'\s*@assert(\w+)\s*\((.*)\)\s*$', re.IGNORECASE)


class PfError(Exception):
    """A problem in a .pf file, at 1-based line `lineno`."""

    def __init__(self, lineno, message):
        super().__init__(message)
        self.lineno = lineno
        self.message = message


# --------------------------------------------------------------------------- output helpers

def byte_len(text):
    return len(text.encode('utf-8', 'surrogateescape'))


def fortran_string(text):
    """A Fortran character literal with the value `text`."""
    return "'" + text.replace("'", "''") + "'"


def line_marker(lineno, path):
    return '#line %d "%s"' % (lineno, path.replace('\\', '\\\\').replace('"', '\\"'))


def split_pieces(stmt):
    """Split a statement into ('str', literal) and ('code', text) pieces; code pieces end after
    a comma or a blank, the preferred places for a line break."""
    pieces = []
    i, n = 0, len(stmt)
    while i < n:
        c = stmt[i]
        if c in '\'"':
            j = i + 1
            while j < n:
                if stmt[j] == c:
                    if j + 1 < n and stmt[j + 1] == c:
                        j += 2
                        continue
                    break
                j += 1
            pieces.append(('str', stmt[i:j + 1]))
            i = j + 1
        else:
            j = i
            while j < n and stmt[j] not in '\'"':
                j += 1
                if stmt[j - 1] in ', ':
                    break
            pieces.append(('code', stmt[i:j]))
            i = j
    return pieces


def split_literal(text, size):
    """A long character literal as a concatenation of literals of at most `size` characters
    each, as pieces.  (Continuing the literal itself on the next line would start that line
    inside a string, which the C preprocessor run on .F90 files does not understand: a "/*"
    there would start a C comment.)"""
    quote, body = text[0], text[1:-1]
    chunks = []
    while body:
        k = min(len(body), max(1, size - 2))
        while k < len(body) and byte_len(body[:k]) > size - 2:
            k -= 1
        # never cut between the two quotes of an escaped quote: count the run of quotes
        # that ends at the cut; an odd count would cut one pair
        run = 0
        while run < k and body[k - 1 - run] == quote:
            run += 1
        if run % 2 == 1 and k < len(body):
            k -= 1 if k > 1 else -1
        chunks.append(body[:k])
        body = body[k:]
    pieces = []
    for i, chunk in enumerate(chunks):
        if i:
            pieces.append(('code', ' // '))
        pieces.append(('str', quote + chunk + quote))
    return pieces


def wrap_statement(stmt, indent):
    """Free-form lines of at most MAX_LINE bytes for one statement: every line but the last
    ends with "&", every continuation line starts with "&".  Lines break at commas and blanks
    where possible, inside longer tokens otherwise (legal with the leading "&"); character
    literals too long for a line are split into a concatenation."""
    cont_prefix = indent + '    &'
    fresh_room = MAX_LINE - byte_len(cont_prefix) - 1   # keep one column for the final "&"
    if fresh_room < 20:
        raise ValueError('indentation too deep to wrap: %d columns' % len(indent))
    lines = []
    cur = indent
    has_content = False

    def room():
        return MAX_LINE - byte_len(cur) - 1

    groups, group = [], []
    for kind, text in split_pieces(stmt):
        if kind == 'str' and byte_len(text) > fresh_room:
            group.extend(split_literal(text, fresh_room - 4))
            continue
        group.append((kind, text))
        # a group ends at a comma or blank outside literals: breaks go between groups first,
        # so that "message='...'" stays together
        if kind == 'code' and text[-1] in ', ':
            groups.append(group)
            group = []
    if group:
        groups.append(group)

    for group in groups:
        size = sum(byte_len(text) for _, text in group)
        if size > room() and has_content and size <= fresh_room:
            lines.append(cur + '&')
            cur, has_content = cont_prefix, False
        for kind, text in group:
            while text:
                if byte_len(text) <= room():
                    cur += text
                    has_content = True
                    break
                if has_content and (kind == 'str' or byte_len(text) <= fresh_room):
                    lines.append(cur + '&')
                    cur, has_content = cont_prefix, False
                    continue
                k = 0
                while k < len(text) and byte_len(text[:k + 1]) <= room():
                    k += 1
                lines.append(cur + text[:k] + '&')
                cur, has_content = cont_prefix, False
                text = text[k:]
    lines.append(cur)
    return lines


# --------------------------------------------------------------------------- directive parsing

def scan_segment(seg, quote):
    """Scan one physical line of a directive.  Returns (content, continued, quote) where
    content excludes a continuation "&" and quote is the open character-literal delimiter."""
    out = []
    k, n = 0, len(seg)
    while k < n:
        c = seg[k]
        if quote:
            if c == quote:
                if k + 1 < n and seg[k + 1] == quote:
                    out.append(c + c)
                    k += 2
                    continue
                quote = None
            elif c == '&' and seg[k + 1:].strip() == '':
                return ''.join(out), True, quote
            out.append(c)
            k += 1
            continue
        if c in '\'"':
            quote = c
        elif c == '!':
            raise ValueError('comment inside a directive (pFUnit does not accept one)')
        elif c == '&':
            rest = seg[k + 1:].strip()
            if rest == '':
                return ''.join(out), True, None
            if rest.startswith('!'):
                raise ValueError('comment inside a directive (pFUnit does not accept one)')
        out.append(c)
        k += 1
    return ''.join(out), False, quote


def gather_directive(lines, start):
    """The text of the directive at index `start`, which must be complete on its line (as for
    pFUnit's funitproc).  Returns (text, index of its last line, i.e. `start`)."""
    try:
        text, continued, quote = scan_segment(lines[start].lstrip(), None)
    except ValueError as e:
        raise PfError(start + 1, str(e))
    if continued:
        raise PfError(start + 1, 'directive continued with "&": pFUnit 4 (funitproc) recognises a directive '
                                 'only on one line and leaves a continued one untranslated; write it on one '
                                 'line (put a long condition into a variable first)')
    if quote:
        raise PfError(start + 1, 'unterminated character literal in directive')
    return text, start


def split_arguments(text, open_index, lineno):
    """Split the argument list whose "(" is text[open_index] at top-level commas.  Returns
    (arguments, index just past the matching ")")."""
    args = []
    depth = 0
    k = open_index + 1
    arg_start = k
    quote = None
    n = len(text)
    while k < n:
        c = text[k]
        if quote:
            if c == quote:
                if k + 1 < n and text[k + 1] == quote:
                    k += 2
                    continue
                quote = None
        elif c in '\'"':
            quote = c
        elif c in '([':
            depth += 1
        elif c in ')]':
            if depth == 0:
                if c != ')':
                    raise PfError(lineno, 'unbalanced brackets in directive')
                args.append(text[arg_start:k].strip())
                return args, k + 1
            depth -= 1
        elif c == ',' and depth == 0:
            args.append(text[arg_start:k].strip())
            arg_start = k + 1
        k += 1
    raise PfError(lineno, 'unbalanced parentheses in directive')


def check_funitproc_length(line, lineno):
    """Reject an assertion line that pFUnit's funitproc would translate into a line longer than
    MAX_LINE: it writes "  call assert<name>(<arguments>, &" (pFUnitParser.py, AtAssert.action)."""
    m = FUNITPROC_ASSERT_RE.match(line)
    if not m:
        return
    args = m.group(2)
    translated = '  call assert%s(%s%s&' % (m.group(1), args, ', ' if args.strip() else '')
    if byte_len(translated) > MAX_LINE:
        raise PfError(lineno, 'pFUnit 4 (funitproc) translates this directive into a line of %d characters, '
                              'more than the %d gfortran accepts; shorten it by at least %d character(s) (e.g. the '
                              'message, or an expression computed into a variable first)'
                      % (byte_len(translated), MAX_LINE, byte_len(translated) - MAX_LINE))


def translate_assertion(text, lineno, pf_name):
    """The Fortran call for a joined assertion directive."""
    m = re.match(r'@(\w+)\s*\(', text)
    if not m:
        raise PfError(lineno, 'expected "(" after @%s' % re.match(r'@(\w*)', text).group(1))
    directive = m.group(1)
    procedure, min_operands, quote_condition = ASSERTIONS[directive.lower()]
    args, end = split_arguments(text, m.end() - 1, lineno)
    if text[end:].strip():
        raise PfError(lineno, 'unexpected text after @%s(...): %s' % (directive, text[end:].strip()))
    if args == ['']:
        args = []
    if any(a == '' for a in args):
        raise PfError(lineno, 'empty argument in @%s' % directive)
    if len(args) < min_operands:
        raise PfError(lineno, '@%s needs at least %d operand(s), found %d'
                      % (directive, min_operands, len(args)))
    expression = None
    for i, arg in enumerate(args):
        km = KEYWORD_RE.match(arg)
        if km and km.group(1).lower() in RESERVED_KEYWORDS:
            raise PfError(lineno, 'keyword %s= is not allowed in @%s' % (km.group(1), directive))
        if quote_condition and i == 0:
            if not km:
                expression = arg
            elif km.group(1).lower() == 'condition':
                expression = arg[km.end():].strip()
    call = 'call %s(%s, location=%s' % (procedure, ', '.join(args),
                                        fortran_string('%s:%d' % (pf_name, lineno)))
    if expression is not None:
        expression = ' '.join(expression.split())
        if len(expression) > MAX_EXPRESSION:
            expression = expression[:MAX_EXPRESSION - 3] + '...'
        call += ', expression=' + fortran_string(expression)
    return call + ')'


def declared_names(line):
    """The entity names of a declaration statement "type-spec[, attributes] :: a, b(3) = ...": the
    leading name of each item after the first "::" outside brackets and literals ([] if none)."""
    depth, quote, k, n = 0, None, 0, len(line)
    items, start = None, None
    while k < n:
        c = line[k]
        if quote:
            if c == quote:
                quote = None
        elif c in '\'"':
            quote = c
        elif c == '!':
            break
        elif c in '([':
            depth += 1
        elif c in ')]':
            depth -= 1
        elif depth == 0 and items is None and line.startswith('::', k):
            items, start = [], k + 2
            k += 2
            continue
        elif depth == 0 and items is not None and c == ',':
            items.append(line[start:k])
            start = k + 1
        k += 1
    if items is None:
        return []
    items.append(line[start:k])
    names = []
    for item in items:
        m = re.match(r'\s*([A-Za-z]\w*)', item)
        if m:
            names.append(m.group(1))
    return names


# --------------------------------------------------------------------------- one .pf file

class TestModule:
    def __init__(self, path):
        self.path = path
        self.base = os.path.splitext(os.path.basename(path))[0]
        self.pf_name = os.path.basename(path)
        self.module = None
        self.tests = []         # subroutine names, in file order
        self.before = None
        self.after = None
        self.output = []        # lines of the translated file
        self.errors = []        # (lineno, message)

    def error(self, lineno, message):
        self.errors.append((lineno, message))

    def translate(self, lines):
        out = self.output
        out.append('! Generated by test/pfunit_lite.py from %s -- do not edit.' % self.path)
        out.append(line_marker(1, self.path))
        pending = None          # ('test' | 'before' | 'after', line number) awaiting a subroutine
        uses_funit = False
        i = 0
        while i < len(lines):
            line = lines[i]
            lineno = i + 1
            stripped = line.strip()
            if pending:
                if stripped == '' or stripped.startswith('!'):
                    out.append(line)
                    i += 1
                    continue
                kind, at = pending
                pending = None
                m = SUBROUTINE_RE.match(line)
                if not m:
                    self.error(at, '@%s must be followed by "subroutine NAME()" (found: %s)'
                               % (kind, stripped[:60]))
                elif m.group(2) and m.group(2)[1:-1].strip():
                    self.error(lineno, 'test procedures with dummy arguments (@testcase style) '
                                       'are not supported: %s' % stripped[:60])
                else:
                    self.register(kind, m.group(1), at)
                    out.append(line)
                    i += 1
                    continue
            if stripped.startswith('@'):
                name = re.match(r'@(\w*)', stripped).group(1)
                low = name.lower()
                if low in ANNOTATIONS:
                    rest = stripped[1 + len(name):].strip()
                    if rest:
                        if low == 'test' and rest.startswith('('):
                            self.error(lineno, 'unsupported directive @test(...): @test options are not '
                                               'supported, use plain @test')
                        else:
                            self.error(lineno, 'unexpected text after @%s: %s' % (name, rest))
                    else:
                        pending = (low, lineno)
                    out.append(line.replace('@', '!@', 1))
                    i += 1
                    continue
                if low in ASSERTIONS:
                    try:
                        text, last = gather_directive(lines, i)
                        check_funitproc_length(line, lineno)
                        call = translate_assertion(text, lineno, self.pf_name)
                    except PfError as e:
                        self.error(e.lineno, e.message)
                        out.append(line)
                        i += 1
                        continue
                    indent = line[:len(line) - len(line.lstrip())]
                    if out[-1].startswith('#line '):
                        out.pop()       # the marker after the previous assertion
                    out.append(line_marker(lineno, self.path))
                    out.extend(wrap_statement(call, indent))
                    out.append(indent + 'if (funit_failed()) return')
                    out.append(line_marker(last + 2, self.path))
                    i = last + 1
                    continue
                self.error(lineno, 'unsupported directive @%s (pfunit_lite supports @test, @before, @after, '
                                   '@assertEqual, @assertTrue, @assertFalse, @assertLessThan[OrEqual], '
                                   '@assertGreaterThan[OrEqual], @assertIsFinite)' % name)
                out.append(line)
                i += 1
                continue
            m = MODULE_RE.match(line)
            if m and m.group(1).lower() != 'procedure':
                if self.module is not None:
                    self.error(lineno, 'more than one module in a .pf file')
                else:
                    self.module = m.group(1)
                    if self.module.lower() != self.base.lower():
                        self.error(lineno, 'module %s must be named after its file (module %s)'
                                   % (self.module, self.base))
            elif MODULE_COMMENT_RE.match(line):
                self.error(lineno, 'write the module statement without a comment '
                                   '(pFUnit does not recognise "module NAME !...")')
            m = USE_FUNIT_RE.match(line)
            if m:
                rest = m.group(1).strip()
                if rest and not rest.startswith('!'):
                    self.error(lineno, 'write just "use funit" (the translated code needs all of funit)')
                uses_funit = True
            out.append(line)
            i += 1
        if pending:
            self.error(pending[1], '@%s at the end of the file without a subroutine' % pending[0])
        self.check_module_names(lines)
        if self.module is None:
            self.error(1, 'no "module %s" statement' % self.base)
        elif not uses_funit:
            self.error(1, 'module %s does not "use funit"' % self.module)
        return not self.errors

    def check_module_names(self, lines):
        """Module procedures, module variables and derived types named like a public name of
        pFUnit's funit (FUNIT_PUBLIC_NAMES).  Internal procedures and local variables may reuse
        those names (they hide the use-associated one).  Declarations are read from the first
        line of each statement only."""
        depth = 0               # open procedures
        in_interface = in_type = False
        in_module = False
        in_contains = False     # after the module's "contains"
        previous_continued = False
        for i, line in enumerate(lines):
            lineno = i + 1
            stripped = line.strip()
            continued = previous_continued
            previous_continued = stripped.endswith('&') and not stripped.startswith('!')
            if stripped == '' or stripped.startswith(('!', '@')) or continued:
                continue
            if not in_module:
                in_module = bool(MODULE_RE.match(line))
                continue
            if in_interface:
                in_interface = not END_INTERFACE_RE.match(line)
                continue
            if in_type:
                in_type = not END_TYPE_RE.match(line)
                continue
            if INTERFACE_RE.match(line):
                in_interface = True
                continue
            m = PROC_START_RE.match(line)
            if m:
                if depth == 0:
                    self.check_name(lineno, m.group(2), 'module procedure')
                depth += 1
                continue
            if depth > 0:
                if PROC_END_RE.match(line):
                    depth -= 1
                continue
            if in_contains:
                continue
            if CONTAINS_RE.match(line):
                in_contains = True
                continue
            m = TYPE_DEF_RE.match(line)
            if m and not re.match(r'\s*type\s*\(', line, re.IGNORECASE):
                self.check_name(lineno, m.group(1), 'derived type')
                in_type = True
                continue
            if NOT_DECLARATION_RE.match(line):
                continue
            for name in declared_names(line):
                self.check_name(lineno, name, 'module variable')

    def check_name(self, lineno, name, what):
        if name.lower() in FUNIT_PUBLIC_NAMES:
            self.error(lineno, '%s %s has the name of a public entity of pFUnit\'s module funit, which the '
                               'test module uses: genuine pFUnit 4 rejects the clash; rename it' % (what, name))

    def register(self, kind, name, lineno):
        if kind == 'test':
            if name.lower() in (t.lower() for t in self.tests):
                self.error(lineno, 'test %s registered twice' % name)
            self.tests.append(name)
        elif getattr(self, kind) is not None:
            self.error(lineno, 'a second @%s (%s; the first is %s)' % (kind, name, getattr(self, kind)))
        else:
            setattr(self, kind, name)


# --------------------------------------------------------------------------- main program

def main_program(modules):
    out = ['! Generated by test/pfunit_lite.py -- do not edit.',
           '! Runs every @test of:']
    for mod in modules:
        out.append('!   ' + mod.path)
    out.append('program pfunit_lite_main')
    body = []
    uses = [('funit', 'funit_run_test', None), ('funit', 'funit_finish', None)]
    for mi, mod in enumerate(modules, 1):
        before = after = None
        if mod.before:
            before = 'pfl_m%d_before' % mi
            uses.append((mod.module, before, mod.before))
        if mod.after:
            after = 'pfl_m%d_after' % mi
            uses.append((mod.module, after, mod.after))
        for ti, test in enumerate(mod.tests, 1):
            alias = 'pfl_m%d_t%d' % (mi, ti)
            uses.append((mod.module, alias, test))
            call = 'call funit_run_test(%s, %s' % (fortran_string('%s::%s' % (mod.module, test)), alias)
            if before:
                call += ', before=' + before
            if after:
                call += ', after=' + after
            body.extend(wrap_statement(call + ')', '   '))
    for module, local, remote in uses:
        stmt = 'use %s, only: %s' % (module, local if remote is None else '%s => %s' % (local, remote))
        out.extend(wrap_statement(stmt, '   '))
    out.append('   implicit none')
    out.extend(body)
    out.append('   call funit_finish()')
    out.append('end program pfunit_lite_main')
    return out


def read_lines(path):
    with open(path, encoding='utf-8', errors='surrogateescape', newline='') as f:
        text = f.read()
    lines = text.split('\n')
    if lines and lines[-1] == '':
        lines.pop()
    return [line.rstrip('\r') for line in lines]


def write_lines(path, lines):
    with open(path, 'w', encoding='utf-8', errors='surrogateescape', newline='\n') as f:
        f.write('\n'.join(lines) + '\n')


def main(argv=None):
    parser = argparse.ArgumentParser(
        description='Translate pFUnit 4 .pf files (a subset) into Fortran for test/lite/funit.f90.')
    parser.add_argument('--out-dir', required=True, help='directory for NAME.F90 and pfunit_lite_main.F90')
    parser.add_argument('pf_files', nargs='*', metavar='FILE.pf')
    args = parser.parse_args(argv)

    modules = []
    failed = False
    seen = {}
    for path in args.pf_files:
        mod = TestModule(path)
        if not path.endswith('.pf'):
            mod.error(1, 'input files must end in .pf')
        elif mod.base.lower() in seen:
            mod.error(1, 'same base name as %s' % seen[mod.base.lower()])
        else:
            seen[mod.base.lower()] = path
            try:
                lines = read_lines(path)
            except OSError as e:
                mod.error(1, 'cannot read: %s' % e.strerror)
            else:
                mod.translate(lines)
        for lineno, message in sorted(mod.errors):
            print('pfunit_lite: %s:%d: %s' % (path, lineno, message), file=sys.stderr)
        failed = failed or bool(mod.errors)
        modules.append(mod)
    if failed:
        print('pfunit_lite: nothing written', file=sys.stderr)
        return 2

    os.makedirs(args.out_dir, exist_ok=True)
    for mod in modules:
        write_lines(os.path.join(args.out_dir, mod.base + '.F90'), mod.output)
    write_lines(os.path.join(args.out_dir, 'pfunit_lite_main.F90'), main_program(modules))
    return 0


if __name__ == '__main__':
    sys.exit(main())
