% A lamp and a switch: the first worked example of the language reference (D.6).
% `cplus plan lamp.cp -n 0` lists the three histories of query 0.

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
