% Two robots carry a payload (after Erdem, Aker, Patoglu et al., "Two robots and a payload",
% the project's main paper).  Each robot is a LEGO arm whose end-effector moves on a grid;
% its magnet holds one end of a metal stick.  Neither robot can carry the stick alone.
%
% The geometry (obstacles, rails, arm lengths, the payload's length and tolerance) lives in
% scene.toml beside this file; the scene provides the external collision/4, so the laws
% below and the continuous checker use the same obstacles.
%
% Parameters (macros):
%   minX..maxX, minY..maxY   the grid (must match [grid] of scene.toml)
%   maxN                     the longest move of one robot in one step, in cells
%   maxCost                  the plan's cost bound (a move of more than one cell costs 1)
%   linklengthsq, tolerance  the payload's squared length and how far it may stretch

:- macros
  minX -> 0;  maxX -> 12;
  minY -> -1; maxY -> 7;
  maxN -> 4;
  maxCost -> 2;
  linklengthsq -> 25;
  tolerance -> 2.

:- maxAdditive :: maxCost.

:- sorts
  robot; end; direction; xcoord; ycoord; stepCount; costValue.

:- objects
  r1, r2                       :: robot;
  pl1, pl2                     :: end;
  up, down, left, right        :: direction;
  minX..maxX                   :: xcoord;
  minY..maxY                   :: ycoord;
  1..maxN                      :: stepCount;
  0..maxCost                   :: costValue.

:- variables
  R, R1                        :: robot;
  P, P1, P2                    :: end;
  D, D1                        :: direction;
  X, X1, X2                    :: xcoord;
  Y, Y1, Y2                    :: ycoord;
  N, N1                        :: stepCount.

:- constants
  xpos(robot)                  :: inertialFluent(xcoord);
  ypos(robot)                  :: inertialFluent(ycoord);
  xpay(end)                    :: inertialFluent(xcoord);
  ypay(end)                    :: inertialFluent(ycoord);
  on(robot,end)                :: sdFluent;
  canCarry                     :: simpleFluent;
  cost                         :: additiveFluent(costValue);
  move(robot,direction)        :: exogenousAction;
  steps(robot,direction)       :: attribute(stepCount) of move(robot,direction).

% Direct effects: a move of N cells in a direction.
move(R,right) causes xpos(R)=X2 if steps(R,right)=N & xpos(R)=X1 where X2 = X1+N.
move(R,left)  causes xpos(R)=X2 if steps(R,left)=N  & xpos(R)=X1 where X2 = X1-N.
move(R,up)    causes ypos(R)=Y2 if steps(R,up)=N    & ypos(R)=Y1 where Y2 = Y1+N.
move(R,down)  causes ypos(R)=Y2 if steps(R,down)=N  & ypos(R)=Y1 where Y2 = Y1-N.

% A move may not leave the grid.
nonexecutable move(R,right) if steps(R,right)=N & xpos(R)=X1 where X1+N > maxX.
nonexecutable move(R,left)  if steps(R,left)=N  & xpos(R)=X1 where X1-N < minX.
nonexecutable move(R,up)    if steps(R,up)=N    & ypos(R)=Y1 where Y1+N > maxY.
nonexecutable move(R,down)  if steps(R,down)=N  & ypos(R)=Y1 where Y1-N < minY.

% Moving in any direction by more than one cell costs 1.
move(R,D) increments cost by 1 if steps(R,D) > 1.

% Ramifications: an end-effector at an end of the payload holds it, and a held end is
% where its robot is.
caused on(R,P) if xpos(R)=xpay(P) & ypos(R)=ypay(P).
default -on(R,P).
caused xpay(P)=X if on(R,P) & xpos(R)=X.
caused ypay(P)=Y if on(R,P) & ypos(R)=Y.

% No opposite directions at once; the Pythagorean range of motion for two directions.
nonexecutable move(R,up) & move(R,down).
nonexecutable move(R,left) & move(R,right).
nonexecutable move(R,D) & move(R,D1)
  if steps(R,D)=N & steps(R,D1)=N1 where D @< D1 & N*N+N1*N1 > maxN*maxN.

% Carrying needs both ends held, by different robots, for one step before moving.
nonexecutable move(R,D) if -canCarry & on(R,P).
caused canCarry if on(r1,P1) & on(r2,P2) & P1\=P2 after on(r1,P1) & on(r2,P2) & P1\=P2.
default -canCarry.

% The paper's laws let an end "follow" a robot through the self-supporting loop between
% on/2 and xpay/ypay (C+ has no loop formulas): an end could jump from one robot to the
% other.  Physically a magnet keeps what it holds, and one end is held by one robot.
caused false if -on(R,P) after on(R,P).
caused false if on(r1,P) & on(r2,P).

% The cost bound.
caused false if cost > maxCost.

% The payload does not move unless carried.
caused false if xpay(P)=X1 & X1\=X2 after -canCarry & xpay(P)=X2.
caused false if ypay(P)=Y1 & Y1\=Y2 after -canCarry & ypay(P)=Y2.

% The payload's length may change by at most the tolerance (its ends are on grid points).
caused false if xpay(pl1)=X1 & xpay(pl2)=X2 & ypay(pl1)=Y1 & ypay(pl2)=Y2
  where (X2-X1)*(X2-X1)+(Y2-Y1)*(Y2-Y1) < linklengthsq-tolerance ++
        (X2-X1)*(X2-X1)+(Y2-Y1)*(Y2-Y1) > linklengthsq+tolerance.

% Obstacles: an end-effector's straight move, and the payload at every state.
caused false if xpos(R)=X1 & ypos(R)=Y1 after xpos(R)=X2 & ypos(R)=Y2
  where between(X2-maxN,X2+maxN,X1) & between(Y2-maxN,Y2+maxN,Y1) & collision(X1,Y1,X2,Y2).
caused false if xpay(pl1)=X1 & ypay(pl1)=Y1 & xpay(pl2)=X2 & ypay(pl2)=Y2
  where collision(X1,Y1,X2,Y2).

:- show xpos(R); ypos(R); xpay(P); ypay(P); cost; move(R,D).

% The paper's query: carry the upright payload from x = 0 to x = 10.
:- query
  label :: 0;
  maxstep :: 0..infinity;
  0: -canCarry, xpos(r1)=0, ypos(r1)=0, xpos(r2)=0, ypos(r2)=5,
     xpay(pl1)=0, ypay(pl1)=0, xpay(pl2)=0, ypay(pl2)=5, cost=0;
  maxstep: xpay(pl1)=10, ypay(pl1)=0, xpay(pl2)=10, ypay(pl2)=5.
