% A lamp and a switch: the first worked example of the language reference (D.6).
% `cplus plan lamp.cp --query 0 -n 0` lists the three histories of query 0; `cplus plan
% lamp.cp` answers every query, then the nmquery (exit code 10: `never` has no plan).

:- constants
  lit     :: inertialFluent;
  flip    :: exogenousAction.

flip causes lit.

% Which histories of length 1 end with the lamp on?  (Three: it was on, or it was flipped on,
% or both.)
:- query
  label :: 0;
  maxstep :: 1;
  1: lit.

% The shortest plan that switches the lamp on.
:- query
  label :: on;
  maxstep :: 0..infinity;
  0: -lit;
  maxstep: lit.

% Nothing switches the lamp off, so no plan of any length does: the invariant `lit` holds
% from the start, excludes the goal and survives every transition (exit code 10).
:- query
  label :: never;
  maxstep :: any;
  invariant: lit;
  0: lit;
  maxstep: -lit.

% CCALC's nmquery (docs/language.md, section 7): lit is true at 1 exactly when flip was done
% at 0.  Three histories; the one where the lamp was on and stayed on unflipped is excluded.
:- nmquery label :: flipped; maxstep :: 1;
   default 0: lit; default 0: -lit; default 0: flip; default 0: -flip;
   caused 1: lit if 0: flip; default 1: -lit.
